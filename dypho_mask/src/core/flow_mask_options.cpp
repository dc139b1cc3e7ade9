#include "dypho/mask/flow_mask_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace dypho {
namespace mask {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("FlowMaskOptions: " + what);
}

}  // namespace

void FlowMaskOptions::validate() const {
  require(std::isfinite(flow_scale) && flow_scale > 0.0 && flow_scale <= 1.0,
          "flow_scale must be in (0, 1], got " + std::to_string(flow_scale));
  require(std::isfinite(residual_threshold_px) && residual_threshold_px > 0.0,
          "residual_threshold_px must be > 0, got " + std::to_string(residual_threshold_px));
  require(min_region_area_px >= 0, "min_region_area_px must be >= 0, got " + std::to_string(min_region_area_px));
  require(dilate_px >= 0, "dilate_px must be >= 0, got " + std::to_string(dilate_px));
  require(std::isfinite(max_masked_fraction) && max_masked_fraction > 0.0 && max_masked_fraction <= 1.0,
          "max_masked_fraction must be in (0, 1], got " + std::to_string(max_masked_fraction));
  require(open_radius_px >= 0, "open_radius_px must be >= 0, got " + std::to_string(open_radius_px));
  require(sample_step_px >= 1, "sample_step_px must be >= 1, got " + std::to_string(sample_step_px));
  require(std::isfinite(ransac_threshold_px) && ransac_threshold_px > 0.0,
          "ransac_threshold_px must be > 0, got " + std::to_string(ransac_threshold_px));
  require(ransac_max_iterations >= 1,
          "ransac_max_iterations must be >= 1, got " + std::to_string(ransac_max_iterations));
  require(std::isfinite(min_inlier_ratio) && min_inlier_ratio >= 0.0 && min_inlier_ratio < 1.0,
          "min_inlier_ratio must be in [0, 1), got " + std::to_string(min_inlier_ratio));
  require(std::isfinite(min_texture_gradient) && min_texture_gradient >= 0.0,
          "min_texture_gradient must be >= 0, got " + std::to_string(min_texture_gradient));
  require(std::isfinite(residual_memory) && residual_memory >= 0.0 && residual_memory < 1.0,
          "residual_memory must be in [0, 1), got " + std::to_string(residual_memory));
  require(std::isfinite(refit_without_previous_margin) && refit_without_previous_margin >= 0.0 &&
              refit_without_previous_margin < 1.0,
          "refit_without_previous_margin must be in [0, 1), got " + std::to_string(refit_without_previous_margin));
  require(stale_prediction_kept_frames_behind >= 0 && stale_prediction_kept_frames_behind <= 1000,
          "stale_prediction_kept_frames_behind must be in [0, 1000], got " +
              std::to_string(stale_prediction_kept_frames_behind));
  require(dis_refinement_iterations >= 0 && dis_refinement_iterations <= 100,
          "dis_refinement_iterations must be in [0, 100], got " + std::to_string(dis_refinement_iterations));
  require(dis_catch_up_patch_stride >= 1 && dis_catch_up_patch_stride <= 64,
          "dis_catch_up_patch_stride must be in [1, 64], got " + std::to_string(dis_catch_up_patch_stride));
  require(dis_catch_up_iterations >= 1 && dis_catch_up_iterations <= 100,
          "dis_catch_up_iterations must be in [1, 100], got " + std::to_string(dis_catch_up_iterations));
}

std::string FlowMaskOptions::toString() const {
  std::ostringstream s;
  s << "flow_scale=" << flow_scale << " residual_threshold_px=" << residual_threshold_px
    << " min_region_area_px=" << min_region_area_px << " dilate_px=" << dilate_px
    << " max_masked_fraction=" << max_masked_fraction << " open_radius_px=" << open_radius_px
    << " sample_step_px=" << sample_step_px << " ransac_threshold_px=" << ransac_threshold_px
    << " ransac_max_iterations=" << ransac_max_iterations << " min_inlier_ratio=" << min_inlier_ratio
    << " min_texture_gradient=" << min_texture_gradient << " aperture_aware=" << (aperture_aware ? "true" : "false")
    << " residual_memory=" << residual_memory << " fit_rigid_motion=" << (fit_rigid_motion ? "true" : "false")
    << " stale_prediction_kept_frames_behind=" << stale_prediction_kept_frames_behind
    << " refit_without_previous_margin=" << refit_without_previous_margin
    << " ultrafast=" << (ultrafast ? "true" : "false") << " dis_refinement_iterations=" << dis_refinement_iterations
    << " dis_catch_up_patch_stride=" << dis_catch_up_patch_stride
    << " dis_catch_up_iterations=" << dis_catch_up_iterations;
  return s.str();
}

}  // namespace mask
}  // namespace dypho
