/// Map quality at the training keyframes (PSNR on static pixels, depth L1, side-by-side images).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "gaussian_trainer.h"

namespace dypho::mapping {

namespace {

/// PSNR of one keyframe on its static pixels, with and without its exposure [dB].
struct KeyframeScore {
  double psnr_db = 0.0;
  double psnr_without_exposure_db = 0.0;
};

/// Renders `kf`, adds its depth errors to `depth_sum`/`depth_n`, writes its side-by-side image
/// when `side_by_side_dir` is set; nullopt when it has no static pixel.
std::optional<KeyframeScore> scoreKeyframe(GaussianTrainer& trainer, const TrainingKeyframe& kf,
                                           const std::string& side_by_side_dir, double* depth_sum,
                                           std::size_t* depth_n) {
  const GaussianMapperOptions& options = trainer.options;
  RenderResult<float>& r = trainer.view_out;
  trainer.renderPinhole(kf.T_world_camera, kf.camera, trainer.render_raster, r);
  const std::size_t npix = static_cast<std::size_t>(r.width) * r.height;
  double se = 0.0, se_raw = 0.0;
  std::size_t ns = 0;
  const bool expose = options.exposure_compensation;
  float gain[3], offset[3];
  for (int ch = 0; ch < 3; ++ch) {
    gain[ch] = expose ? std::exp(kf.exposure[ch]) : 1.f;
    offset[ch] = expose ? kf.exposure[3 + ch] : 0.f;
  }
  cv::Mat rendered(r.height, r.width, CV_8UC3), rdepth(r.height, r.width, CV_32FC1);
  for (int v = 0; v < r.height; ++v) {
    const std::uint8_t* m = kf.static_mask.ptr<std::uint8_t>(v);
    const float* d = kf.depth_m.ptr<float>(v);
    const cv::Vec3b* c = kf.bgr.ptr<cv::Vec3b>(v);
    for (int u = 0; u < r.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * r.width + u;
      for (int ch = 0; ch < 3; ++ch) {
        const float raw = std::min(1.f, std::max(0.f, r.color[ch * npix + i]));
        const float x = std::min(1.f, std::max(0.f, gain[ch] * r.color[ch * npix + i] + offset[ch]));
        rendered.at<cv::Vec3b>(v, u)[2 - ch] = static_cast<std::uint8_t>(x * 255.f + 0.5f);
        if (m[u]) {
          const double diff = x - c[u][2 - ch] / 255.0, diff_raw = raw - c[u][2 - ch] / 255.0;
          se += diff * diff;
          se_raw += diff_raw * diff_raw;
        }
      }
      rdepth.at<float>(v, u) = r.depth[i];
      if (m[u]) ++ns;
      if (m[u] && d[u] > 0.f) {
        *depth_sum += std::abs(r.depth[i] - d[u]);
        ++*depth_n;
      }
    }
  }
  if (ns == 0) return std::nullopt;
  const KeyframeScore score{10.0 * std::log10(1.0 / std::max(se / (3.0 * ns), 1e-10)),
                            10.0 * std::log10(1.0 / std::max(se_raw / (3.0 * ns), 1e-10))};
  if (!side_by_side_dir.empty()) {
    auto colorize = [&](const cv::Mat& depth) {
      cv::Mat d8, out;
      depth.convertTo(d8, CV_8U, 255.0 / options.valid_max_depth_m);
      cv::applyColorMap(d8, out, cv::COLORMAP_JET);
      out.setTo(cv::Scalar(0, 0, 0), depth <= 0.f);
      return out;
    };
    cv::Mat input = kf.bgr.clone();
    input.setTo(cv::Scalar(255, 0, 255), kf.static_mask == 0);  // dynamic pixels in magenta
    cv::Mat top, bottom, all;
    cv::hconcat(input, rendered, top);
    cv::hconcat(colorize(kf.depth_m), colorize(rdepth), bottom);
    cv::vconcat(top, bottom, all);
    const std::string path = side_by_side_dir + "/kf_" + std::to_string(kf.id) + ".png";
    if (!cv::imwrite(path, all)) throw std::runtime_error("cannot write '" + path + "' (does the folder exist?)");
  }
  return score;
}

/// 0..n-1 in an order spread over the whole range (bit-reversed counting: first, middle,
/// quarters, ...), so that evaluating a prefix of it samples the whole run.
std::vector<std::size_t> spreadOrder(std::size_t n) {
  std::size_t bits = 0;
  while ((std::size_t{1} << bits) < n) ++bits;
  std::vector<std::size_t> order;
  order.reserve(n);
  for (std::size_t i = 0; i < (std::size_t{1} << bits); ++i) {
    std::size_t reversed = 0;
    for (std::size_t b = 0; b < bits; ++b) reversed |= ((i >> b) & 1u) << (bits - 1 - b);
    if (reversed < n) order.push_back(reversed);
  }
  return order;
}

}  // namespace

KeyframeEvaluation evaluateKeyframes(GaussianTrainer& trainer, const std::string& side_by_side_dir,
                                     std::optional<double> budget_s) {
  const auto t0 = std::chrono::steady_clock::now();
  trainer.syncToHost();  // renders the current map on the host
  KeyframeEvaluation ev;
  double depth_sum = 0.0;
  std::size_t depth_n = 0;
  std::vector<std::optional<KeyframeScore>> scores(trainer.keyframes.size());
  for (const std::size_t i : spreadOrder(trainer.keyframes.size())) {
    const TrainingKeyframe& kf = trainer.keyframes[i];
    if (!kf.hasImages()) continue;
    ++ev.num_keyframes_stored;
    const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (budget_s && elapsed_s > *budget_s) continue;  // past the budget: counted, not rendered
    scores[i] = scoreKeyframe(trainer, kf, side_by_side_dir, &depth_sum, &depth_n);
  }
  for (const std::optional<KeyframeScore>& score : scores) {  // keyframe order
    if (!score) continue;
    ev.psnr_per_keyframe_db.push_back(score->psnr_db);
    ev.psnr_without_exposure_db += score->psnr_without_exposure_db;
  }
  ev.num_keyframes = ev.psnr_per_keyframe_db.size();
  for (double p : ev.psnr_per_keyframe_db) ev.psnr_db += p;
  if (ev.num_keyframes) {
    ev.psnr_db /= ev.num_keyframes;
    ev.psnr_without_exposure_db /= ev.num_keyframes;
  }
  ev.depth_l1_m = depth_n ? depth_sum / depth_n : 0.0;
  return ev;
}

}  // namespace dypho::mapping
