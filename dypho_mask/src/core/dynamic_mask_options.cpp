#include "dypho/mask/dynamic_mask_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "dypho/mask/mask_options_fields.h"
#include "dypho/mask/yolo_decoder.h"

namespace dypho {
namespace mask {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("DynamicMaskOptions: " + what);
}

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

std::vector<int> YoloOptions::dynamicClassIds() const {
  std::vector<int> ids;
  std::stringstream ss(dynamic_classes);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto b = item.find_first_not_of(" \t");
    if (b == std::string::npos) continue;
    const auto e = item.find_last_not_of(" \t");
    const std::string t = item.substr(b, e - b + 1);
    size_t used = 0;
    int id = -1;
    try {
      id = std::stoi(t, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    require(used == t.size() && id >= 0 && id < 1000,
            "yolo_dynamic_classes must be comma-separated class ids >= 0, got '" + dynamic_classes + "'");
    ids.push_back(id);
  }
  require(!ids.empty(), "yolo_dynamic_classes is empty (list at least one class id, 0 = person)");
  return ids;
}

void YoloOptions::validate() const {
  parseYoloLayout(layout);  // throws with the valid names
  require(input_size_px >= 32 && input_size_px % 32 == 0,
          "yolo_input_size_px must be a multiple of 32 >= 32, got " + std::to_string(input_size_px));
  require(std::isfinite(score_threshold) && score_threshold > 0.0 && score_threshold < 1.0,
          "yolo_score_threshold must be in (0, 1), got " + num(score_threshold));
  require(std::isfinite(nms_iou) && nms_iou > 0.0 && nms_iou <= 1.0,
          "yolo_nms_iou must be in (0, 1], got " + num(nms_iou));
  dynamicClassIds();
  require(every_n_frames >= 1, "yolo_every_n_frames must be >= 1, got " + std::to_string(every_n_frames));
  require(max_age_frames >= 0 && max_age_frames <= 1000,
          "yolo_max_age_frames must be in [0, 1000], got " + std::to_string(max_age_frames));
  require(async_backoff_max_frames >= 0 && async_backoff_max_frames <= 1000,
          "yolo_async_backoff_max_frames must be in [0, 1000], got " + std::to_string(async_backoff_max_frames));
  require(async_nice >= 0 && async_nice <= 19, "yolo_async_nice must be in [0, 19], got " + std::to_string(async_nice));
  require(std::isfinite(box_depth_range_m) && box_depth_range_m > 0.0,
          "yolo_box_depth_range_m must be > 0, got " + num(box_depth_range_m));
}

void BackgroundOptions::validate() const {
  require(std::isfinite(scale) && scale > 0.0 && scale <= 1.0, "background_scale must be in (0, 1], got " + num(scale));
  require(std::isfinite(tau) && tau >= 0.0 && tau < 1.0, "background_tau must be in [0, 1), got " + num(tau));
  require(std::isfinite(rho) && rho > 0.0 && rho < 1.0, "background_rho must be in (0, 1), got " + num(rho));
  require(
      tau + rho < 1.0,
      "background_tau + background_rho must be < 1 (the weight of B_{i-1} is 1 - tau - rho), got " + num(tau + rho));
  require(std::isfinite(sigma_m) && sigma_m > 0.0, "background_sigma_m must be > 0, got " + num(sigma_m));
  require(std::isfinite(motion_tolerance) && motion_tolerance >= 0.0 && motion_tolerance <= 2.0,
          "background_motion_tolerance must be in [0, 2], got " + num(motion_tolerance));
  require(window_px >= 3 && window_px % 2 == 1,
          "background_window_px must be odd and >= 3, got " + std::to_string(window_px));
  require(min_agreeing >= 0 && min_agreeing < window_px * window_px,
          "background_min_agreeing must be in [0, window_px^2), got " + std::to_string(min_agreeing));
  require(grow_max_ratio >= 0.0 && std::isfinite(grow_max_ratio),
          "background_grow_max_ratio must be finite and >= 0, got " + std::to_string(grow_max_ratio));
  require(veto_after_updates >= 0,
          "background_veto_after_updates must be >= 0, got " + std::to_string(veto_after_updates));
  require(warp_error_min_share >= 0.0 && warp_error_min_share <= 1.0,
          "background_warp_error_min_share must be in [0, 1], got " + std::to_string(warp_error_min_share));
}

void DynamicMaskOptions::validate() const {
  yolo.validate();
  flow.validate();
  background.validate();
  require(margin_px >= 0, "margin_px must be >= 0, got " + std::to_string(margin_px));
  require(catch_up_frames_waiting >= 0 && catch_up_frames_waiting <= 1000,
          "catch_up_frames_waiting must be in [0, 1000], got " + std::to_string(catch_up_frames_waiting));
  require(permanence_frames >= 0 && permanence_frames <= 10000,
          "permanence_frames must be in [0, 10000], got " + std::to_string(permanence_frames));
  require(moving_permanence_frames >= 0 && moving_permanence_frames <= 10000,
          "moving_permanence_frames must be in [0, 10000], got " + std::to_string(moving_permanence_frames));
  require(depth_layers >= 1, "depth_layers must be >= 1, got " + std::to_string(depth_layers));
  require(min_region_area_px >= 0, "min_region_area_px must be >= 0, got " + std::to_string(min_region_area_px));
}

std::string DynamicMaskOptions::toString() const {
  std::ostringstream s;
  DynamicMaskOptions copy = *this;
  bool first = true;
  visitOptions(copy, [&](const std::string& key, const auto& value, const char*) {
    s << (first ? "" : " ") << key << '=';
    if constexpr (std::is_same_v<std::decay_t<decltype(value)>, bool>) {
      s << (value ? "true" : "false");
    } else if constexpr (std::is_same_v<std::decay_t<decltype(value)>, std::string>) {
      s << '"' << value << '"';
    } else {
      s << value;
    }
    first = false;
  });
  return s.str();
}

}  // namespace mask
}  // namespace dypho
