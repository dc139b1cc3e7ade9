#include "dypho/tracking/tracking_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "dypho/tracking/tracking_options_fields.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {
namespace {

template <typename T>
void requireRange(const char* name, T value, T lo, T hi, bool lo_open = false) {
  const bool ok = std::isfinite(static_cast<double>(value)) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok) {
    std::ostringstream os;
    os << "TrackingOptions." << name << " = " << value << " is out of range " << (lo_open ? "(" : "[") << lo << ", "
       << hi << "]; fix the parameter (see tracking_options.h for its meaning)";
    throw std::invalid_argument(os.str());
  }
}

/// The dense refinement's ranges (TrackingOptions::dense_*).
void validateDense(const TrackingOptions& o) {
  requireRange("dense_scale", o.dense_scale, 0.1, 1.0);
  requireRange("dense_levels", o.dense_levels, 1, 5);
  requireRange("dense_iterations", o.dense_iterations, 1, 50);
  requireRange("dense_feature_prior_weight", o.dense_feature_prior_weight, 0.0, 1e6);
  requireRange("dense_depth_sigma_per_m2", o.dense_depth_sigma_per_m2, 0.0, 0.1, true);
  requireRange("dense_max_correction_m", o.dense_max_correction_m, 0.0, 1.0, true);
  requireRange("dense_max_correction_deg", o.dense_max_correction_deg, 0.0, 180.0, true);
  requireRange("dense_max_frame_rotation_deg", o.dense_max_frame_rotation_deg, 0.0, 180.0, true);
}

/// The fuse step's and local BA's ranges (TrackingOptions::fuse_*, local_ba_*).
void validateLocalMapping(const TrackingOptions& o) {
  requireRange("fuse_keyframes", o.fuse_keyframes, 0, 50);
  requireRange("fuse_radius_px", o.fuse_radius_px, 0.0, 50.0, true);
  requireRange("fuse_max_hamming_distance", o.fuse_max_hamming_distance, 1, 256);
  requireRange("fuse_max_depth_ratio", o.fuse_max_depth_ratio, 0.0, 1.0, true);
  requireRange("local_ba_keyframes", o.local_ba_keyframes, 0, 50);
  requireRange("local_ba_iterations", o.local_ba_iterations, 1, 100);
  requireRange("local_ba_depth_baseline_m", o.local_ba_depth_baseline_m, 0.0, 1.0);
  requireRange("local_ba_max_fixed_keyframes", o.local_ba_max_fixed_keyframes, 1, 100);
  requireRange("local_ba_async_frames", o.local_ba_async_frames, 0, 30);
}

/// Loop closure, the pose graph and global BA.
void validateLoopAndGlobalBa(const TrackingOptions& o) {
  requireRange("loop_min_keyframe_gap", o.loop_min_keyframe_gap, 2, 100000);
  requireRange("loop_search_radius_m", o.loop_search_radius_m, 0.0, 100.0, true);
  requireRange("loop_max_angle_deg", o.loop_max_angle_deg, 0.0, 180.0, true);
  requireRange("loop_max_candidates", o.loop_max_candidates, 1, 100);
  requireRange("loop_min_inliers", o.loop_min_inliers, o.min_inliers, 10000);
  requireRange("loop_edge_weight", o.loop_edge_weight, 0.0, 1000.0, true);
  requireRange("pose_graph_min_shared", o.pose_graph_min_shared, 1, 100000);
  requireRange("pose_graph_sigma_rot_deg", o.pose_graph_sigma_rot_deg, 0.0, 90.0, true);
  requireRange("pose_graph_sigma_trans_m", o.pose_graph_sigma_trans_m, 0.0, 10.0, true);
  requireRange("pose_graph_iterations", o.pose_graph_iterations, 1, 1000);
  requireRange("correction_min_translation_m", o.correction_min_translation_m, 0.0, 1.0);
  requireRange("correction_min_rotation_rad", o.correction_min_rotation_rad, 0.0, 1.0);
  requireRange("global_ba_iterations", o.global_ba_iterations, 1, 100);
  requireRange("global_ba_prior_sigma_deg", o.global_ba_prior_sigma_deg, 0.0, 90.0);
  requireRange("global_ba_prior_sigma_m", o.global_ba_prior_sigma_m, 0.0, 10.0);
  requireRange("global_ba_max_seconds", o.global_ba_max_seconds, 0.1, 3600.0);
  requireRange("final_frame_refinement_max_frames", o.final_frame_refinement_max_frames, 0, 1000000);
  requireRange("final_frame_refinement_max_seconds", o.final_frame_refinement_max_seconds, 0.1, 3600.0);
  requireRange("final_frame_refinement_max_masked_fraction", o.final_frame_refinement_max_masked_fraction, 0.0, 1.0);
  requireRange("trajectory_smoothing_s", o.trajectory_smoothing_s, 0.0, 1.0);
  requireRange("trajectory_smoothing_outlier_sigmas", o.trajectory_smoothing_outlier_sigmas, 0.0, 100.0);
}

}  // namespace

void TrackingOptions::validate() const {
  requireRange("num_features", num_features, 50, 20000);
  requireRange("scale_factor", scale_factor, 1.0, 2.0, true);
  requireRange("num_levels", num_levels, 1, 16);
  requireRange("fast_threshold", fast_threshold, 1, 254);
  requireRange("min_fast_threshold", min_fast_threshold, 1, fast_threshold);
  requireRange("grid_cell_px", grid_cell_px, 8, 200);
  requireRange("mask_border_px", mask_border_px, 0, 50);
  requireRange("mask_threshold_relaxation", mask_threshold_relaxation, 0.0, 1.0);
  requireRange("relaxed_sigma0", relaxed_sigma0, 0.0, 1.0, true);
  requireRange("relaxed_k", relaxed_k, 0.0, 1.0);
  requireRange("relaxed_min_count", relaxed_min_count, 0, 15);
  requireRange("min_depth_m", min_depth_m, 0.0, 100.0, true);
  requireRange("max_depth_m", max_depth_m, min_depth_m, 100.0, true);
  requireRange("max_hamming_distance", max_hamming_distance, 1, 256);
  requireRange("ratio_test", ratio_test, 0.0, 1.0, true);
  requireRange("search_radius_px", search_radius_px, 1.0, 200.0);
  requireRange("refine_search_radius_px", refine_search_radius_px, 0.5, 50.0);
  requireRange("wide_search_radius_px", wide_search_radius_px, 0.0, 300.0);
  requireRange("max_level_difference", max_level_difference, 0, num_levels - 1);
  requireRange("ratio_test_same_level_max_rotation_deg", ratio_test_same_level_max_rotation_deg, 0.0, 180.0);
  requireRange("ransac_iterations", ransac_iterations, 10, 100000);
  requireRange("ransac_reprojection_px", ransac_reprojection_px, 0.0, 50.0, true);
  requireRange("min_inliers", min_inliers, 6, 10000);
  requireRange("huber_px", huber_px, 0.0, 100.0, true);
  requireRange("refine_iterations", refine_iterations, 1, 1000);
  requireRange("outlier_rounds", outlier_rounds, 1, 20);
  requireRange("chi2_threshold", chi2_threshold, 0.0, 100.0, true);
  requireRange("depth_baseline_m", depth_baseline_m, 0.0, 1.0);
  requireRange("chi2_threshold_depth", chi2_threshold_depth, 0.0, 100.0, true);
  if (rolling_shutter_readout_ms != -1.0) {
    requireRange("rolling_shutter_readout_ms", rolling_shutter_readout_ms, 0.0, 100.0);
  }
  requireRange("rolling_shutter_rate_sigma_rad_s", rolling_shutter_rate_sigma_rad_s, 0.0, 100.0, true);
  requireRange("rolling_shutter_rate_sigma_ratio", rolling_shutter_rate_sigma_ratio, 0.0, 10.0);
  requireRange("rolling_shutter_velocity_sigma_m_s", rolling_shutter_velocity_sigma_m_s, 0.0, 100.0, true);
  requireRange("motion_blur_exposure_ms", motion_blur_exposure_ms, 0.0, 100.0);
  requireRange("motion_blur_min_rate_rad_s", motion_blur_min_rate_rad_s, 0.0, 100.0);
  requireRange("keyframe_translation_m", keyframe_translation_m, 0.0, 10.0, true);
  requireRange("keyframe_rotation_deg", keyframe_rotation_deg, 0.0, 180.0, true);
  requireRange("keyframe_min_tracked_ratio", keyframe_min_tracked_ratio, 0.0, 1.0);
  requireRange("keyframe_sharp_tracked_ratio", keyframe_sharp_tracked_ratio, keyframe_min_tracked_ratio, 1.0);
  requireRange("keyframe_sharp_max_frame_rotation_deg", keyframe_sharp_max_frame_rotation_deg, 0.0, 180.0, true);
  requireRange("keyframe_max_frames", keyframe_max_frames, 1, 100000);
  requireRange("keyframe_max_frame_rotation_deg", keyframe_max_frame_rotation_deg, 0.0, 180.0, true);
  requireRange("keyframe_hard_tracked_ratio", keyframe_hard_tracked_ratio, 0.0, keyframe_min_tracked_ratio);
  requireRange("keyframe_static_doubt", keyframe_static_doubt, 0.0, 1.0);
  requireRange("min_init_features", min_init_features, min_inliers, 20000);
  requireRange("max_lost_frames", max_lost_frames, 1, 100000);
  requireRange("local_map_keyframes", local_map_keyframes, 0, 100);
  requireRange("covisibility_min_shared", covisibility_min_shared, 1, 10000);
  requireRange("local_map_nearby_keyframes", local_map_nearby_keyframes, 0, 100);
  requireRange("local_map_nearby_max_angle_deg", local_map_nearby_max_angle_deg, 0.0, 180.0, true);
  requireRange("local_map_nearby_max_distance_m", local_map_nearby_max_distance_m, 0.0, 100.0, true);
  requireRange("cull_min_found_ratio", cull_min_found_ratio, 0.0, 1.0);
  requireRange("moving_point_min_hits", moving_point_min_hits, 0, 1000);
  requireRange("moving_point_depth_tolerance_m", moving_point_depth_tolerance_m, 0.0, 1.0, true);
  requireRange("first_keyframe_moving_hits", first_keyframe_moving_hits, 0, 1000);
  requireRange("point_probation_frames", point_probation_frames, 0, 100);
  requireRange("point_probation_max_refuted", point_probation_max_refuted, 1, 100);
  requireRange("point_probation_min_verified", point_probation_min_verified, min_inliers, 10000);
  requireRange("static_check_min_gain", static_check_min_gain, 0.0, 1.0, true);
  requireRange("static_check_scale", static_check_scale, 0.1, 1.0);
  requireRange("static_check_max_frame_rotation_deg", static_check_max_frame_rotation_deg, 0.0, 180.0, true);
  validateDense(*this);
  requireRange("keyframe_cull_redundant_ratio", keyframe_cull_redundant_ratio, 0.0, 1.0);
  validateLocalMapping(*this);
  requireRange("catch_up_frames_waiting", catch_up_frames_waiting, 0, 1000);
  requireRange("relocalization_max_keyframes", relocalization_max_keyframes, 1, 10000);
  requireRange("relocalization_min_inliers", relocalization_min_inliers, min_inliers, 10000);
  requireRange("localization_max_jump_m", localization_max_jump_m, 0.0, 100.0, true);
  requireRange("localization_max_jump_deg", localization_max_jump_deg, 0.0, 180.0, true);
  requireRange("localization_confident_inliers", localization_confident_inliers, min_inliers, 100000);
  validateLoopAndGlobalBa(*this);
}

std::string TrackingOptions::toString() const {
  std::ostringstream os;
  os << std::boolalpha;
  TrackingOptions copy = *this;  // the visitor takes non-const references
  visitOptions(copy,
               [&os](const char* key, const auto& value, const char* /*doc*/) { os << key << ": " << value << "\n"; });
  return os.str();
}

const char* toString(TrackingState state) {
  switch (state) {
    case TrackingState::kNotInitialized:
      return "NOT_INITIALIZED";
    case TrackingState::kOk:
      return "OK";
    case TrackingState::kLost:
      return "LOST";
  }
  return "UNKNOWN";
}

}  // namespace tracking
}  // namespace dypho
