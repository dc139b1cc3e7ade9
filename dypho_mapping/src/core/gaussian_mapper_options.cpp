#include "dypho/mapping/gaussian_mapper_options.h"

#include <sstream>
#include <stdexcept>

#include "dypho/common/thread_budget.h"
#include "dypho/mapping/mapping_options_fields.h"

namespace dypho::mapping {
namespace {

void require(bool ok, const char* field, const char* range) {
  if (!ok) throw std::invalid_argument(std::string("GaussianMapperOptions: ") + field + " must be " + range);
}

}  // namespace

void GaussianMapperOptions::validate() const {
  require(device == "auto" || device == "cpu" || device == "cuda", "device", "auto, cpu or cuda");
  require(sh_degree >= 0 && sh_degree <= 3, "sh_degree", "in [0, 3]");
  require(max_gaussians >= 1, "max_gaussians", ">= 1");
  require(num_threads >= 0, "num_threads", ">= 0");
  require(train_downsample == 1 || train_downsample == 2 || train_downsample == 4, "train_downsample", "1, 2 or 4");
  require(iterations_per_keyframe >= 0, "iterations_per_keyframe", ">= 0");
  require(live_min_iterations_per_keyframe >= 0, "live_min_iterations_per_keyframe", ">= 0");
  require(live_cpu_training_duty > 0.0 && live_cpu_training_duty <= 1.0, "live_cpu_training_duty", "in (0, 1]");
  require(training_nice >= 0 && training_nice <= 19, "training_nice", "in [0, 19]");
  require(final_refine_iterations >= 0, "final_refine_iterations", ">= 0");
  require(window_size >= 1, "window_size", ">= 1");
  require(max_stored_keyframes >= 1, "max_stored_keyframes", ">= 1");
  require(lambda_depth >= 0 && lambda_depth <= 1, "lambda_depth", "in [0, 1]");
  require(alpha_weight >= 0, "alpha_weight", ">= 0");
  require(ssim_weight >= 0, "ssim_weight", ">= 0");
  require(isotropy_weight >= 0, "isotropy_weight", ">= 0");
  require(lr_exposure >= 0, "lr_exposure", ">= 0");
  require(lr_pose_translation_m >= 0, "lr_pose_translation_m", ">= 0");
  require(lr_pose_rotation_rad >= 0, "lr_pose_rotation_rad", ">= 0");
  require(pose_refinement_max_translation_m > 0, "pose_refinement_max_translation_m", "> 0");
  require(pose_refinement_max_rotation_rad > 0, "pose_refinement_max_rotation_rad", "> 0");
  require(global_sample_ratio >= 0 && global_sample_ratio <= 1, "global_sample_ratio", "in [0, 1]");
  require(valid_min_depth_m >= 0 && valid_max_depth_m > valid_min_depth_m, "valid_min_depth_m/valid_max_depth_m",
          ">= 0 and max > min");
  require(initial_opacity > 0 && initial_opacity < 1, "initial_opacity", "in (0, 1)");
  require(feature_samples >= 0, "feature_samples", ">= 0");
  require(feature_sample_radius_px > 0, "feature_sample_radius_px", "> 0");
  require(coverage_stride_px >= 1, "coverage_stride_px", ">= 1");
  require(coverage_alpha_threshold >= 0 && coverage_alpha_threshold <= 1, "coverage_alpha_threshold", "in [0, 1]");
  require(coverage_depth_error_ratio > 0, "coverage_depth_error_ratio", "> 0");
  require(
      lr_position >= 0 && lr_log_scale >= 0 && lr_rotation >= 0 && lr_opacity >= 0 && lr_sh_dc >= 0 && lr_sh_rest >= 0,
      "lr_*", ">= 0");
  require(densify_interval >= 0, "densify_interval", ">= 0");
  require(densify_grad_threshold > 0, "densify_grad_threshold", "> 0");
  require(densify_scale_threshold_m > 0, "densify_scale_threshold_m", "> 0");
  require(prune_min_opacity >= 0 && prune_min_opacity < 1, "prune_min_opacity", "in [0, 1)");
  require(prune_max_scale_m > 0, "prune_max_scale_m", "> 0");
  require(opacity_reset_interval >= 0, "opacity_reset_interval", ">= 0");
}

int GaussianMapperOptions::resolvedNumThreads() const {
  return num_threads > 0 ? num_threads : planThreadBudget(0).mapping_threads;
}

std::string GaussianMapperOptions::toString() const {
  std::ostringstream os;
  GaussianMapperOptions copy = *this;
  bool first = true;
  visitOptions(copy, [&](const char* key, const auto& value, const char*) {
    os << (first ? "" : " ") << key << "=" << value;
    first = false;
  });
  return os.str();
}

}  // namespace dypho::mapping
