#pragma once
/// \file tracking_options_fields.h
/// The list of TrackingOptions keys, written once: parameter readers (ROS private params, YAML
/// files) and printers visit the fields through `visitOptions`. Keep it in the order of the struct.

#include "dypho/tracking/tracking_options.h"

namespace dypho::tracking {

/// Calls `visitor(key, field, doc)` for every field of `options`.
template <typename Visitor>
void visitOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor("num_features", options.num_features, "Keypoints wanted per frame over all pyramid levels [count]; default 1000, range [50, 20000].");
  visitor("scale_factor", options.scale_factor, "Scale ratio between consecutive pyramid levels [-]; default 1.2, range (1.0, 2.0].");
  visitor("num_levels", options.num_levels, "Number of pyramid levels [count]; default 8, range [1, 16].");
  visitor("fast_threshold", options.fast_threshold, "FAST intensity threshold in normal cells [grey levels]; default 20, range [1, 254].");
  visitor("min_fast_threshold", options.min_fast_threshold, "FAST threshold retried in grid cells where `fast_threshold` found nothing [grey levels]; default 7, range [1, fast_threshold].");
  visitor("grid_cell_px", options.grid_cell_px, "Grid cell size on each pyramid level for spreading keypoints [px of that level]; default 30, range [8, 200].");
  visitor("mask_border_px", options.mask_border_px, "Keypoints keep this distance from every dynamic (masked) pixel, scaled by the level scale, so that descriptors do not straddle the mask border [px at level 0]; default 4, range [0, 50].");
  visitor("mask_threshold_relaxation", options.mask_threshold_relaxation, "Paper's relaxed features (sigma_dy = sigma_0 (1 - k * masked fraction)): the FAST threshold is multiplied by (1 - k * masked_fraction), never below `min_fast_threshold` [-]; default 0.5, range [0, 1]; 0 disables.");
  visitor("min_depth_m", options.min_depth_m, "Keypoints with a depth below this are dropped [m]; default 0.1, range (0, max_depth_m).");
  visitor("max_depth_m", options.max_depth_m, "Keypoints with a depth above this are dropped [m]; default 6.0, range (min_depth_m, 100].");
  visitor("max_hamming_distance", options.max_hamming_distance, "Largest accepted Hamming distance between two 256-bit ORB descriptors [bits]; default 64, range [1, 256].");
  visitor("ratio_test", options.ratio_test, "Lowe ratio: best distance must be below ratio_test * second best [-]; default 0.8, (0, 1].");
  visitor("search_radius_px", options.search_radius_px, "Search radius around the constant-velocity prediction, multiplied by the keyframe point's level scale [px at level 0]; default 15, range [1, 200].");
  visitor("refine_search_radius_px", options.refine_search_radius_px, "Search radius of the second, refining projection pass around the first pose estimate [px at level 0]; default 4, range [0.5, 50].");
  visitor("max_level_difference", options.max_level_difference, "Projection-guided search accepts candidates whose pyramid level differs by at most this from the keyframe point's level [levels]; default 1 (ORB-SLAM), range [0, num_levels - 1].");
  visitor("ransac_iterations", options.ransac_iterations, "RANSAC iterations of cv::solvePnPRansac [count]; default 200, range [10, 100000].");
  visitor("ransac_reprojection_px", options.ransac_reprojection_px, "RANSAC inlier threshold on undistorted pixels [px]; default 3.0, range (0, 50].");
  visitor("min_inliers", options.min_inliers, "Fewest pose inliers for a frame to count as tracked [count]; default 15, range [6, 10000].");
  visitor("huber_px", options.huber_px, "Huber threshold on the whitened reprojection residual (px / sigma_level) [px]; default 2.0, range (0, 100].");
  visitor("refine_iterations", options.refine_iterations, "Levenberg-Marquardt iterations per optimisation round [count]; default 10, range [1, 1000].");
  visitor("outlier_rounds", options.outlier_rounds, "Rounds of optimise-then-reclassify outliers by chi2 (ORB-SLAM style) [count]; default 3, range [1, 20].");
  visitor("chi2_threshold", options.chi2_threshold, "chi2 threshold (2 dof) separating inliers from outliers on the whitened residual [-]; default 5.991 (95 %), range (0, 100].");
  visitor("depth_baseline_m", options.depth_baseline_m, "Virtual stereo baseline b that turns the depth measured in the current frame into a third residual u - b fx / z (ORB-SLAM RGB-D style; Kinect ~0.075 m) [m]; default 0 = reprojection only, range [0, 1]. Off by default: on TUM fr1/rpy the colour and depth images are not exposed at the same instant, and under fast rotation the depth residual raised the ATE from 2.7 cm to 8-10 cm; the keyframe depth (3D points) is used either way.");
  visitor("chi2_threshold_depth", options.chi2_threshold_depth, "chi2 threshold (3 dof) for observations with the depth residual [-]; default 7.815 (95 %), range (0, 100].");
  visitor("keyframe_translation_m", options.keyframe_translation_m, "New keyframe when the camera moved more than this since the last keyframe [m]; default 0.10, range (0, 10].");
  visitor("keyframe_rotation_deg", options.keyframe_rotation_deg, "New keyframe when the camera rotated more than this since the last keyframe [deg]; default 8, range (0, 180].");
  visitor("keyframe_min_tracked_ratio", options.keyframe_min_tracked_ratio, "New keyframe when fewer than this fraction of the keyframe's points are pose inliers [-]; default 0.6, range [0, 1].");
  visitor("keyframe_max_frames", options.keyframe_max_frames, "New keyframe at the latest after this many frames since the last keyframe [frames]; default 20, range [1, 100000].");
  visitor("keyframe_max_frame_rotation_deg", options.keyframe_max_frame_rotation_deg, "The four triggers above are postponed while the camera rotated more than this between the last two frames: such frames suffer from motion blur, rolling shutter and colour/depth time offset, and a keyframe anchors every following frame [deg/frame]; default 1.5, range (0, 180]. On fr1/rpy (keyframe_rotation_deg 6..15) this gave 2.2-2.5 cm ATE against 3.0-5.4 cm without it; the result is sensitive to which frames become keyframes (1.25: ~4.4 cm, 1.75: 2.3-3.9).");
  visitor("keyframe_hard_tracked_ratio", options.keyframe_hard_tracked_ratio, "A keyframe is made regardless of the rotation speed when the tracked ratio falls below this or fewer than 3 * min_inliers inliers remain [-]; default 0.3, range [0, keyframe_min_tracked_ratio].");
  visitor("min_init_features", options.min_init_features, "Fewest keypoints with valid depth needed to start (or restart) on a frame [count]; default 100, range [min_inliers, 20000].");
  visitor("max_lost_frames", options.max_lost_frames, "After this many consecutive lost frames a new keyframe is started at the last good pose [frames]; default 5, range [1, 100000].");
}

}  // namespace dypho::tracking
