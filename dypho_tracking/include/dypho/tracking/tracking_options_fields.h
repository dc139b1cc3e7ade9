#pragma once
/// \file tracking_options_fields.h
/// The list of TrackingOptions keys, written once: parameter readers (ROS private params, YAML
/// files) and printers visit the fields through `visitOptions`. Keep it in the order of the struct.

#include "dypho/tracking/tracking_options.h"

namespace dypho::tracking {

/// ORB extraction and the relaxed feature test (TrackingOptions).
template <typename Visitor>
void visitOrbOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor("num_features", options.num_features,
          "Keypoints wanted per frame over all pyramid levels [count]; default 1000, range [50, 20000].");
  visitor("scale_factor", options.scale_factor,
          "Scale ratio between consecutive pyramid levels [-]; default 1.2, range (1.0, 2.0].");
  visitor("num_levels", options.num_levels, "Number of pyramid levels [count]; default 8, range [1, 16].");
  visitor("fast_threshold", options.fast_threshold,
          "FAST intensity threshold in normal cells [grey levels]; default 20, range [1, 254].");
  visitor("min_fast_threshold", options.min_fast_threshold,
          "FAST threshold retried in grid cells where `fast_threshold` found nothing [grey levels]; default 7, range "
          "[1, fast_threshold].");
  visitor(
      "grid_cell_px", options.grid_cell_px,
      "Grid cell size on each pyramid level for spreading keypoints [px of that level]; default 30, range [8, 200].");
  visitor("mask_border_px", options.mask_border_px,
          "Keypoints keep this distance from every dynamic (masked) pixel, scaled by the level scale, so that "
          "descriptors do not straddle the mask border [px at level 0]; default 4, range [0, 50].");
  visitor("mask_threshold_relaxation", options.mask_threshold_relaxation,
          "FAST threshold relaxation under the mask: the threshold is multiplied by (1 - k * masked_fraction), never "
          "below `min_fast_threshold` [-]; default 0.5, range [0, 1]; 0 disables.");
  visitor("relaxed_features", options.relaxed_features,
          "Paper's relaxed feature test on masked frames, filling the keypoint budget FAST leaves in cells without a "
          "corner: more than relaxed_min_count of the 16 FAST-ring pixels differ from the centre by more than sigma_dy "
          "times the local grey range (at least fast_threshold), sigma_dy = relaxed_sigma0 (1 - relaxed_k * "
          "masked_fraction); default true (Bonn crowd ATE 1.34 cm on, 1.47 cm off with the detector mask; see "
          "tracking_options.h).");
  visitor("relaxed_sigma0", options.relaxed_sigma0,
          "Initial threshold sigma_0 of the relaxed test [fraction of the local grey range]; default 0.3 (paper), "
          "range (0, 1].");
  visitor("relaxed_k", options.relaxed_k,
          "k of sigma_dy = sigma_0 (1 - k * masked_fraction) [-]; default 0.9 (paper), range [0, 1].");
  visitor("relaxed_min_count", options.relaxed_min_count,
          "n_f: a relaxed feature needs more than this many of the 16 ring pixels to differ [count]; default 12 "
          "(paper), range [0, 15].");
}

/// Depth range, matching, the initial pose and its refinement (TrackingOptions).
template <typename Visitor>
void visitPoseOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor("min_depth_m", options.min_depth_m,
          "Keypoints with a depth below this are dropped [m]; default 0.1, range (0, max_depth_m).");
  visitor("max_depth_m", options.max_depth_m,
          "Keypoints with a depth above this are dropped [m]; default 6.0, range (min_depth_m, 100].");
  visitor("max_hamming_distance", options.max_hamming_distance,
          "Largest accepted Hamming distance between two 256-bit ORB descriptors [bits]; default 64, range [1, 256].");
  visitor("ratio_test", options.ratio_test,
          "Lowe ratio: best distance must be below ratio_test * second best [-]; default 0.8, (0, 1].");
  visitor("search_radius_px", options.search_radius_px,
          "Search radius around the constant-velocity prediction, multiplied by the keyframe point's level scale [px "
          "at level 0]; default 15, range [1, 200].");
  visitor("refine_search_radius_px", options.refine_search_radius_px,
          "Search radius of the second, refining projection pass around the first pose estimate [px at level 0]; "
          "default 4, range [0.5, 50].");
  visitor("wide_search_radius_px", options.wide_search_radius_px,
          "When matching around the prediction fails (a jerk of the hand, dropped frames), it is tried once more "
          "within this radius before the global search [px at level 0]; default 0 = off (45 raised the fr1/rpy ATE), "
          "range [0, 300]; not above search_radius_px = off.");
  visitor("max_level_difference", options.max_level_difference,
          "Projection-guided search accepts candidates whose pyramid level differs by at most this from the keyframe "
          "point's level [levels]; default 1 (ORB-SLAM), range [0, num_levels - 1].");
  visitor("ratio_test_same_level_max_rotation_deg", options.ratio_test_same_level_max_rotation_deg,
          "On a sharp frame of a moving camera (the motion model's last step turned it less than this per frame, and "
          "the camera is not still) the projection search applies the ratio test only between candidates at the same "
          "pyramid level for the verified points (ORB-SLAM): a corner found again at the next level is the same "
          "corner, not an ambiguity [deg/frame]; default 0 = off (every candidate competes on every frame; 1.0 gains "
          "in crowds, loses on fr1/rpy through the graph), range [0, 180].");
  visitor("ransac_iterations", options.ransac_iterations,
          "RANSAC iterations of cv::solvePnPRansac [count]; default 200, range [10, 100000].");
  visitor("ransac_reprojection_px", options.ransac_reprojection_px,
          "RANSAC inlier threshold on undistorted pixels [px]; default 3.0, range (0, 50].");
  visitor("min_inliers", options.min_inliers,
          "Fewest pose inliers for a frame to count as tracked [count]; default 15, range [6, 10000].");
  visitor(
      "huber_px", options.huber_px,
      "Huber threshold on the whitened reprojection residual (px / sigma_level) [px]; default 2.0, range (0, 100].");
  visitor("refine_iterations", options.refine_iterations,
          "Levenberg-Marquardt iterations per optimisation round [count]; default 10, range [1, 1000].");
  visitor("outlier_rounds", options.outlier_rounds,
          "Rounds of optimise-then-reclassify outliers by chi2 (ORB-SLAM style) [count]; default 3, range [1, 20].");
  visitor("chi2_threshold", options.chi2_threshold,
          "chi2 threshold (2 dof) separating inliers from outliers on the whitened residual [-]; default 5.991 (95 %), "
          "range (0, 100].");
  visitor("depth_baseline_m", options.depth_baseline_m,
          "Virtual stereo baseline b that turns the depth measured in the current frame into a third residual u - b fx "
          "/ z (ORB-SLAM RGB-D style; Kinect ~0.075 m) [m]; default 0 = reprojection only, range [0, 1]");
  visitor("chi2_threshold_depth", options.chi2_threshold_depth,
          "chi2 threshold (3 dof) for observations with the depth residual [-]; default 7.815 (95 %), range (0, 100].");
  visitor("rolling_shutter_readout_ms", options.rolling_shutter_readout_ms,
          "Readout time of the colour camera's rolling shutter, top row to bottom row, the middle row at the stamp "
          "[ms]; default -1 = the camera file's (dataset runner; the ROS nodelet: global shutter), 0 = global "
          "shutter, range {-1} or [0, 100]. With a readout the pose refinement also estimates the camera's angular "
          "velocity and projects each point with the pose of its keypoint's row.");
  visitor("rolling_shutter_rate_sigma_rad_s", options.rolling_shutter_rate_sigma_rad_s,
          "Prior standard deviation, about the motion model's rate, of the angular velocity estimated with a rolling "
          "shutter [rad/s]; default 0.15, range (0, 100].");
  visitor("rolling_shutter_rate_sigma_ratio", options.rolling_shutter_rate_sigma_ratio,
          "The same prior widened on fast turns: its standard deviation is the larger of "
          "rolling_shutter_rate_sigma_rad_s and this ratio times the motion model's rate [-]; default 0.25, range "
          "[0, 10]; 0 = a fixed width. Frames slower than 0.6 rad/s keep the tight prior; with 0.25 fr1/rpy's fifteen "
          "frame-removal inputs went 1.36 -> 1.25 cm.");
  visitor("rolling_shutter_velocity_sigma_m_s", options.rolling_shutter_velocity_sigma_m_s,
          "Prior standard deviation, about the motion model's, of the linear velocity estimated with a rolling "
          "shutter [m/s]; default 0.1, range (0, 100].");
  visitor("motion_blur_exposure_ms", options.motion_blur_exposure_ms,
          "Exposure time of the colour camera, for its motion blur [ms]; default 4, range [0, 100]; 0 = sharp (off). "
          "On a fast turn each keypoint's pixel residual in the pose refinement is weighted by its blur streak (the "
          "image velocity under the motion model's velocities times the exposure): sigma along the streak "
          "sqrt(sigma^2 + L^2 / 12), across it sigma. 4 ms: the low end of the keypoints' measured spread along "
          "their streaks.");
  visitor("motion_blur_min_rate_rad_s", options.motion_blur_min_rate_rad_s,
          "The blur is weighted only on frames whose motion model turns at least this fast [rad/s]; default 0.5, "
          "range [0, 100]. People crossing a still camera's view drag its motion model; weighted by that seeming "
          "motion's streaks, the keypoints would give way along it.");
  visitor("motion_blur_in_bundle_adjustment", options.motion_blur_in_bundle_adjustment,
          "A keyframe keeps the blur its pose refinement weighted, and local and global bundle adjustment weight its "
          "keypoints by the same streaks, so a keyframe made in a fast turn gives way along them instead of carrying "
          "their scatter into its pose and points. Default true.");
}

/// Keyframe decisions (TrackingOptions).
template <typename Visitor>
void visitKeyframeOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor(
      "keyframe_translation_m", options.keyframe_translation_m,
      "New keyframe when the camera moved more than this since the last keyframe [m]; default 0.10, range (0, 10].");
  visitor(
      "keyframe_rotation_deg", options.keyframe_rotation_deg,
      "New keyframe when the camera rotated more than this since the last keyframe [deg]; default 8, range (0, 180].");
  visitor("keyframe_min_tracked_ratio", options.keyframe_min_tracked_ratio,
          "New keyframe when fewer than this fraction of the keyframe's points are pose inliers [-]; default 0.6, "
          "range [0, 1].");
  visitor("keyframe_sharp_tracked_ratio", options.keyframe_sharp_tracked_ratio,
          "On a sharp frame (the camera turned less than keyframe_sharp_max_frame_rotation_deg since the previous "
          "frame) the tracked-ratio trigger fires already below this fraction (ORB-SLAM's RGB-D ratio), unless the "
          "tracker is in catch-up mode or the camera still [-]; range [keyframe_min_tracked_ratio, 1]; default 0.6 = "
          "keyframe_min_tracked_ratio, one ratio for every frame (0.75 gains on moving crowds, loses on still ones).");
  visitor("keyframe_sharp_max_frame_rotation_deg", options.keyframe_sharp_max_frame_rotation_deg,
          "A frame counts as sharp for keyframe_sharp_tracked_ratio while the camera turned less than this since the "
          "previous frame [deg/frame]; default 1, range (0, 180].");
  visitor("keyframe_max_frames", options.keyframe_max_frames,
          "New keyframe at the latest after this many frames since the last keyframe [frames]; default 20, range [1, "
          "100000].");
  visitor("keyframe_max_frame_rotation_deg", options.keyframe_max_frame_rotation_deg,
          "The four triggers above are postponed while the camera rotated more than this between the last two frames: "
          "such frames suffer from motion blur, rolling shutter and colour/depth time offset, and a keyframe anchors "
          "every following frame [deg/frame]; default 4 (120 deg/s at 30 Hz), range (0, 180]. Too low a value starves "
          "the map during a long fast turn until a hard trigger makes the keyframe at the worst frame.");
  visitor("keyframe_hard_tracked_ratio", options.keyframe_hard_tracked_ratio,
          "A keyframe is made regardless of the rotation speed when the tracked ratio falls below this or fewer than 3 "
          "* min_inliers inliers remain [-]; default 0.3, range [0, keyframe_min_tracked_ratio].");
  visitor("keyframe_static_doubt", options.keyframe_static_doubt,
          "The periodic keyframe (keyframe_max_frames) is postponed while the static check's refined pose explains "
          "more than this share of the reference keyframe's static samples beyond the tracked pose without having "
          "replaced it: the pose is in doubt (moving matches may be carrying it, and a keyframe would anchor the next "
          "frames and their static checks to it); at most keyframe_max_frames frames more [-]; default 0.02, range [0, "
          "1]; 0 = never postponed.");
  visitor("keyframe_wait_while_disputed", options.keyframe_wait_while_disputed,
          "Soft keyframe triggers wait while the static check disputes the tracked pose: it replaced the feature pose "
          "with its dense pose itself because the matches, re-estimated from that pose, preferred another one. A "
          "keyframe anchors the next frames and their static checks, so one made on a pose that its matches and its "
          "pixels dispute carries that pose on (a person's arm the mask missed can pull the dense pose). Hard triggers "
          "never wait; the others at most until 2 * keyframe_max_frames frames since the keyframe. Default true.");
  visitor("min_init_features", options.min_init_features,
          "Fewest keypoints with valid depth needed to start (or restart) on a frame [count]; default 100, range "
          "[min_inliers, 20000].");
  visitor("max_lost_frames", options.max_lost_frames,
          "After this many consecutive lost frames a new keyframe is started at the last good pose [frames]; default "
          "5, range [1, 100000].");
}

/// The local map and moving points (TrackingOptions).
template <typename Visitor>
void visitLocalMapOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor("local_map_keyframes", options.local_map_keyframes,
          "Frames are tracked against the map points of the last keyframe and of its this many most covisible "
          "keyframes [count]; default 10, range [0, 100]; 0 = the last keyframe only.");
  visitor("covisibility_min_shared", options.covisibility_min_shared,
          "Fewest shared map points for two keyframes to count as covisible [count]; default 15, range [1, 10000].");
  visitor("local_map_nearby_keyframes", options.local_map_nearby_keyframes,
          "The local map of tracking also takes up to this many keyframes that look at the same part of the scene as "
          "the reference keyframe, whether or not they share points with it: optical axes within "
          "local_map_nearby_max_angle_deg and centres within local_map_nearby_max_distance_m, the closest view first "
          "[count]; default 10, range [0, 100]; 0 = covisible keyframes only. Ties each sweep of fast turns to the "
          "first: the generator's kinect-fast case over 900 frames went 7.14 -> 4.46 and 8.82 -> 3.55 cm.");
  visitor("local_map_nearby_max_angle_deg", options.local_map_nearby_max_angle_deg,
          "Largest angle between the optical axes of the reference keyframe and a keyframe of its view [deg]; "
          "default 20, range (0, 180].");
  visitor("local_map_nearby_max_distance_m", options.local_map_nearby_max_distance_m,
          "Largest distance between the centres of the reference keyframe and a keyframe of its view [m]; default "
          "0.3, range (0, 100].");
  visitor("cull_min_found_ratio", options.cull_min_found_ratio,
          "A map point predicted visible in >= 10 frames but a pose inlier in fewer than this fraction of them is "
          "removed [-]; default 0.25, range [0, 1]; 0 disables culling.");
  visitor("moving_point_min_hits", options.moving_point_min_hits,
          "A map point is removed as moving once it was seen on a dynamic surface in at least this many tracked frames "
          "and in at least as many as it was a pose inlier: its projection fell on the dynamic mask at its own depth, "
          "or it was matched but the depth measured there disagreed with it [count]; default 2, range [0, 1000]; 0 "
          "disables. Removes points of people who stood still when their keyframe was made and then walk on. Counted "
          "on every frame it raised TUM fr1/rpy from 2.93 to 4.95 cm (the flow mask's halo on a fast-turning camera), "
          "hence moving_point_still_only.");
  visitor("moving_point_still_only", options.moving_point_still_only,
          "Only sightings while the camera is still count for moving_point_min_hits (the tracked motion of the last "
          "frame under 5 mm and 0.2 deg): before a still camera the flow mask has no ego-motion error, so what it "
          "calls dynamic moves; default true.");
  visitor("moving_point_depth_tolerance_m", options.moving_point_depth_tolerance_m,
          "Depth agreement of a map point with the depth measured at its projection, for the moving-point test: "
          "|z_measured - z_point| below max(this, 0.015 z^2) [m] (z in metres; the quadratic part follows the RGB-D "
          "noise); default 0.05, range (0, 1].");
  visitor("first_keyframe_moving_hits", options.first_keyframe_moving_hits,
          "Safe start: the first keyframe after a start or a re-initialisation is built before any mask could judge "
          "its pixels (the flow needs a previous frame). Its points stay unverified until the next keyframe: one seen "
          "on a dynamic surface (moving-point test) in this many tracked frames is removed, however often it was a "
          "pose inlier [count]; default 3, range [0, 1000]; 0 disables.");
}

/// Map point probation and the static-scene check (TrackingOptions).
template <typename Visitor>
void visitMapPointOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor("point_probation_frames", options.point_probation_frames,
          "Probation of new map points: a point a keyframe created carries the pose only after it agreed (chi2) with "
          "the pose of the verified points on this many tracked frames; until then each frame's pose is estimated from "
          "the verified points first, and an unverified match that disagrees with that pose is an outlier. Catches the "
          "fresh points a person the mask missed keeps giving while keyframes come every few frames, where the "
          "moving-point test (moving_point_still_only) does not look. Not while the camera is still [frames]; default "
          "3, range [0, 100]; 0 = off.");
  visitor("point_probation_max_refuted", options.point_probation_max_refuted,
          "An unverified point that disagreed with the verified points' pose on this many frames is removed as moving "
          "and handed to the mask [count]; default 2, range [1, 100].");
  visitor("point_probation_min_verified", options.point_probation_min_verified,
          "Fewest verified matches for the verified-first estimate; with fewer (a start, a new view) every match "
          "carries the pose as without probation [count]; default 40, range [min_inliers, 10000].");
  visitor("static_check", options.static_check,
          "Dense check of each tracked pose against the reference keyframe's static pixels: the feature pose is "
          "refined photometrically over the keyframe's unmasked, textured pixels; when the refined pose explains "
          "static_check_min_gain more of them, moving matches carried the feature pose and it is re-estimated from the "
          "matches that agree with the refined one. Default true.");
  visitor("static_check_min_gain", options.static_check_min_gain,
          "Share of the keyframe's static samples the refined pose must explain beyond the feature pose before it "
          "replaces it [-]; default 0.05, range (0, 1].");
  visitor("static_check_other_starts", options.static_check_other_starts,
          "The static check's refinement may also start from the last frame's pose and from the reference keyframe's, "
          "whichever of them and the feature pose explains most static samples: moving matches can drag the feature "
          "pose out of the refinement's reach a little more on each frame. Default true.");
  visitor("static_check_scale", options.static_check_scale,
          "Working resolution of the static check (the refinement also runs at half of it) [-]; default 0.5, range "
          "[0.1, 1].");
  visitor("static_check_max_frame_rotation_deg", options.static_check_max_frame_rotation_deg,
          "The static check runs only while the camera turned less than this between the last two frames: motion blur "
          "and rolling-shutter skew bias the photometric comparison [deg/frame]; default 0.5, range (0, 180].");
  visitor("dense_refinement", options.dense_refinement,
          "Dense refinement of every tracked frame: photometric and depth residuals over the reference keyframe's "
          "static pixels, coarse to fine, t-distribution weights, depth residuals weighted by the depth noise; the "
          "feature pose is a prior with its own information, so both form one cost. Skipped in catch-up mode. "
          "Default false: it lost on every shared sequence and on the generator's fast turns "
          "(docs/journal/benchmarks-2026.md, section 21).");
  visitor("dense_scale", options.dense_scale,
          "Finest working resolution of the dense refinement [-]; default 0.5, range [0.1, 1].");
  visitor("dense_levels", options.dense_levels,
          "Pyramid levels of the dense refinement, each half the previous [count]; default 3, range [1, 5].");
  visitor("dense_iterations", options.dense_iterations,
          "Gauss-Newton iterations per level of the dense refinement [count]; default 8, range [1, 50].");
  visitor("dense_feature_prior_weight", options.dense_feature_prior_weight,
          "Weight of the feature pose's information in the dense cost [-]; default 1, range [0, 1e6]; 0 = dense "
          "residuals alone.");
  visitor("dense_depth_sigma_per_m2", options.dense_depth_sigma_per_m2,
          "Depth noise sigma(z) = k z^2 weighting the dense depth residuals [1/m]; default 1.425e-3 (Kinect v1), "
          "range (0, 0.1].");
  visitor("dense_max_correction_m", options.dense_max_correction_m,
          "A dense correction moving the feature pose further than this is not taken [m]; default 0.05, range (0, "
          "1].");
  visitor("dense_max_correction_deg", options.dense_max_correction_deg,
          "A dense correction turning the feature pose further than this is not taken [deg]; default 2, range (0, "
          "180].");
  visitor("dense_max_frame_rotation_deg", options.dense_max_frame_rotation_deg,
          "The dense refinement runs only while the camera turned less than this per frame interval: under faster "
          "turns motion blur and rolling-shutter skew bias the pixels more than the features [deg/frame]; default 1, "
          "range (0, 180].");
}

/// Local BA, catching up, relocalisation, loop closure and corrections (TrackingOptions).
template <typename Visitor>
void visitBackEndOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor("keyframe_cull_redundant_ratio", options.keyframe_cull_redundant_ratio,
          "After each keyframe, a keyframe of its local map (not the oldest) is removed when at least this fraction of "
          "its map points is seen by >= 3 other keyframes at the same or a finer scale (ORB-SLAM's rule; bounds the "
          "map while the camera stays in known places) [-]; default 0.9, range [0, 1]; 0 keeps every keyframe.");
  visitor("fuse_keyframes", options.fuse_keyframes,
          "Fuse step after each keyframe (keyframe_point_fuser.h): its points are matched in this many of its most "
          "covisible keyframes and theirs in it; duplicates are merged, features without a point observe the one they "
          "match [count]; range [0, 50]; default 0 = off: with 10 it gained on Bonn with the flow mask only and cost "
          "on fr1/rpy (docs/journal/benchmarks-2026.md section 13).");
  visitor("fuse_radius_px", options.fuse_radius_px,
          "Search radius of the fuse step around a point's projection, times its level scale [px at level 0]; default "
          "3 (ORB-SLAM), range (0, 50].");
  visitor("fuse_max_hamming_distance", options.fuse_max_hamming_distance,
          "Largest Hamming distance of a fused match [bits]; default 50 (ORB-SLAM's TH_LOW), range [1, 256].");
  visitor("fuse_max_depth_ratio", options.fuse_max_depth_ratio,
          "Largest difference between a feature's measured depth and the projected point's, relative to that depth "
          "[-]; default 0.05, range (0, 1].");
  visitor("local_ba_keyframes", options.local_ba_keyframes,
          "Keyframes whose poses local BA optimises: the new one and its most covisible ones [count]; default 5, range "
          "[0, 50]; 0 disables local BA.");
  visitor("local_ba_iterations", options.local_ba_iterations,
          "Levenberg-Marquardt iterations of each of the two local BA rounds [count]; default 5, range [1, 100].");
  visitor("local_ba_depth_baseline_m", options.local_ba_depth_baseline_m,
          "Virtual stereo baseline of the depth term of local BA (BaRgbdError's third row: b f_x (1/z - 1/z_meas), "
          "same sigma as the pixels); it fixes the metric scale [m]; default 0.08 (Kinect-like), range [0, 1]; "
          "0 = rep");
  visitor("local_ba_max_fixed_keyframes", options.local_ba_max_fixed_keyframes,
          "Most keyframes held fixed in local BA (those seeing the window's points most) [count]; default 10, range "
          "[1, 100].");
  visitor("local_ba_async_frames", options.local_ba_async_frames,
          "Local BA of a new keyframe runs on its own thread on a copy of its window while the next frames are "
          "tracked; its result, with the point and keyframe culling and the loop detection that follow it, is applied "
          "at the start of the frame this many frames later, or before the next keyframe when that comes first, "
          "waiting for it when it has not finished [frames]; default 0, range [0, 30]; 0 = at once, inside the "
          "keyframe's frame. Where it is applied depends on frame counts only, so runs stay repeatable.");
  visitor("catch_up_frames_waiting", options.catch_up_frames_waiting,
          "A frame is tracked in catch-up mode when at least this many frames wait behind it (the live graph fell "
          "behind the camera, e.g. on a loaded machine): a keyframe made then skips its local BA, its heaviest work "
          "(ORB-SLAM's local mapping aborts its BA when keyframes queue up; the next keyframe's window covers this "
          "one), and every frame skips the aligner's tight second projection pass (about a quarter of the tracking "
          "thread's time). The tracker then catches up instead of dropping frames. The static check still runs: "
          "without it a crowd can carry the pose [frames]; default 4 (about 130 ms behind at 30 Hz), range [0, 1000]; "
          "0 = never. "
          "The offline runner never waits.");
  visitor(
      "relocalization_max_keyframes", options.relocalization_max_keyframes,
      "Keyframes tried per lost frame, newest first then spread over the map [count]; default 20, range [1, 10000].");
  visitor("relocalization_min_inliers", options.relocalization_min_inliers,
          "Fewest pose inliers to accept a relocalisation [count]; default 30, range [min_inliers, 10000].");
  visitor("loop_closure", options.loop_closure, "Detect and close loops at each new keyframe; default true.");
  visitor("loop_min_keyframe_gap", options.loop_min_keyframe_gap,
          "Candidates are at least this many keyframes older than the new one; also the pause after a closed loop "
          "[keyframes]; default 20, range [2, 100000].");
  visitor("loop_search_radius_m", options.loop_search_radius_m,
          "Candidates' camera centre within this distance of the new keyframe's (drift must stay below it) [m]; "
          "default 1.0, range (0, 100].");
  visitor("loop_max_angle_deg", options.loop_max_angle_deg,
          "Candidates' optical axis within this angle of the new keyframe's [deg]; default 45, range (0, 180].");
  visitor("loop_max_candidates", options.loop_max_candidates,
          "Candidates verified per keyframe, nearest first [count]; default 3, range [1, 100].");
  visitor("loop_min_inliers", options.loop_min_inliers,
          "Fewest pose inliers to accept a loop [count]; default 50, range [min_inliers, 10000].");
  visitor("loop_edge_weight", options.loop_edge_weight,
          "Weight of the loop edge relative to the odometry/covisibility edges [-]; default 1, range (0, 1000].");
  visitor("pose_graph_min_shared", options.pose_graph_min_shared,
          "Covisibility edges of the pose graph need this many shared points [count]; default 100, range [1, 100000].");
  visitor("pose_graph_sigma_rot_deg", options.pose_graph_sigma_rot_deg,
          "Rotation standard deviation of a pose-graph edge [deg]; default 0.5, range (0, 90].");
  visitor("pose_graph_sigma_trans_m", options.pose_graph_sigma_trans_m,
          "Translation standard deviation of a pose-graph edge [m]; default 0.01, range (0, 10].");
  visitor("pose_graph_iterations", options.pose_graph_iterations,
          "Levenberg-Marquardt iterations of the pose graph [count]; default 20, range [1, 1000].");
  visitor("correction_min_translation_m", options.correction_min_translation_m,
          "A keyframe moved by local BA or loop closure by more than this is sent to mapping, which re-anchors its "
          "Gaussians [m]; default 0.001, range [0, 1].");
  visitor("correction_min_rotation_rad", options.correction_min_rotation_rad,
          "The same for rotation [rad]; default 0.001 (0.057 deg), range [0, 1].");
}

/// Global bundle adjustment (TrackingOptions), the last block of the struct.
template <typename Visitor>
void visitGlobalBaOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor(
      "global_ba_after_loop", options.global_ba_after_loop,
      "Run a global BA (every keyframe and map point) right after each closed loop, synchronously on the tracking "
      "thread; default false: 1.4-2.7 s on the 600-frame synthetic loop (82 keyframes), far beyond a frame's 33 ms, "
      "and no better final trajectory when global_ba_at_end runs.");
  visitor("global_ba_at_end", options.global_ba_at_end,
          "Run a global BA at the end of a run (offline runner before trajectory.txt is written, tracking nodelet at "
          "shutdown before it saves); the saved trajectory follows the adjusted keyframes; default true: with the "
          "keyframe-pair prior it gains on the shared windows' fifteen frame-removal inputs (means fr1/rpy 1.42 -> "
          "1.36, Bonn crowd flow 1.37 -> 1.34, detector 1.35 -> 1.31 cm). Time bounded by global_ba_max_seconds.");
  visitor("global_ba_iterations", options.global_ba_iterations,
          "Levenberg-Marquardt iterations of each of the two global BA rounds (outliers removed in between) [count]; "
          "default 10 (ORB-SLAM), range [1, 100].");
  visitor("global_ba_prior_sigma_deg", options.global_ba_prior_sigma_deg,
          "Global BA holds each keyframe near its pose relative to the keyframe before it as the map had it: prior "
          "standard deviation of their relative rotation [deg]; default 0.5 (the pose graph's edge sigma), range "
          "[0, 90]; 0 (with global_ba_prior_sigma_m 0): no prior. Keeps a keyframe whose points lie in a small patch "
          "of the image from sliding sideways against a turn (12 cm on Bonn crowd with every 15th frame removed).");
  visitor("global_ba_prior_sigma_m", options.global_ba_prior_sigma_m,
          "The same prior on their relative translation [m]; default 0.01 (the pose graph's), range [0, 10].");
  visitor("global_ba_max_seconds", options.global_ba_max_seconds,
          "Wall-time budget of one global BA, both rounds together [s] (each round stops with its best solution so "
          "far); default 4: the tracking nodelet runs the final global BA in its shutdown and roslaunch sends SIGTERM "
          "15 s after SIGINT. Range [0.1, 3600].");
  visitor("final_frame_refinement", options.final_frame_refinement,
          "After the final global BA, each tracked frame's pose is optimised once more against the final positions "
          "of the map points it matched (the tracking estimator, from its saved pose, with its own keypoints, depths "
          "and velocities); the saved trajectory takes it when at least min_inliers inliers remain. A frame was "
          "tracked against points that later local BAs and the global BA refined; its pose relative to its keyframe "
          "does not follow them. A pose the static check or the dense refinement set is kept as it is (it came "
          "from pixels, not from its matches). Default false: it gains on static scenes (TUM fr1/rpy 0.59 -> 0.56 "
          "cm) and loses a little in a crowd (Bonn crowd 1.02 -> 1.04 cm); on for a scene without people.");
  visitor("final_frame_refinement_max_frames", options.final_frame_refinement_max_frames,
          "The newest this many tracked frames keep their inlier observations for the final refinement (about 10 KB "
          "per frame); older frames keep their tracked pose [frames]; default 1800 (one minute at 30 Hz, about 18 MB), "
          "range [0, 1000000]; 0 = none kept.");
  visitor("final_frame_refinement_max_masked_fraction", options.final_frame_refinement_max_masked_fraction,
          "Only frames whose mask called at most this share of the image dynamic are refined: with movers in view, "
          "points on people who stood still may be among the inliers, and the tracked pose (checked by the static "
          "check) is kept [-]; default 0.05, range [0, 1]; 1 = every frame (it lost on the Bonn crowd window).");
  visitor("final_frame_refinement_max_seconds", options.final_frame_refinement_max_seconds,
          "Wall-time budget of the final refinement [s]: it goes from the newest frame back, and the frames it did "
          "not reach keep their tracked pose; default 2 (about 1000 frames on one core of a 2-core VM; the tracking "
          "nodelet refines inside its shutdown, after the final global BA), range [0.1, 3600].");
  visitor("trajectory_smoothing_s", options.trajectory_smoothing_s,
          "The saved trajectory (trajectory.txt, not the poses published at frame time): each frame's position is "
          "the straight line fitted in time through its segment's positions within +- this many seconds [s]; default "
          "0.075 (+-2 frames at 30 Hz): the per-frame translation noise is white, a camera's motion smooth; the "
          "window divides the noise by about sqrt(5) and follows a 1 m/s^2 acceleration to about 1 mm. Rotations are "
          "kept. 0 = off; range [0, 1].");
  visitor("trajectory_smoothing_outlier_sigmas", options.trajectory_smoothing_outlier_sigmas,
          "The same fit made robust: a position farther from its fit than this many sigma (from the median distance "
          "of all positions to their fits) weighs less, as 1 / distance (Huber), in three more fits [-]; default 3: "
          "Gaussian noise is fitted as before, a frame centimetres off (a blurred frame in a fast turn) no longer "
          "pulls its neighbours. 0 = plain least squares; range [0, 100].");
}

/// Localisation in a loaded map (TrackingOptions), after the global BA block.
template <typename Visitor>
void visitLocalizationOptions(TrackingOptions& options, Visitor&& visitor) {
  visitor("localization_only", options.localization_only,
          "Localise only in the map of a restored session (dypho_run_dataset --resume --localization-only): no "
          "keyframes, map points, culling, BA or loop closure change it; a lost frame searches the map by "
          "relocalisation, never a new segment; without a loaded map nothing is tracked; default false.");
  visitor("localization_max_jump_m", options.localization_max_jump_m,
          "Localisation only: a pose (tracked or relocalised) farther than this from the constant-velocity "
          "prediction (the last good pose after a loss; the limit grows per frame lost since) is refused as lost "
          "unless it has localization_confident_inliers inliers; not applied while a restored map is searched [m]; "
          "default 0.2, range (0, 100].");
  visitor("localization_max_jump_deg", options.localization_max_jump_deg,
          "The same for the rotation [deg]; default 5, range (0, 180].");
  visitor("localization_confident_inliers", options.localization_confident_inliers,
          "Inliers from which a pose that strays from the prediction is still accepted in localisation only "
          "[count]; default 200, range [min_inliers, 100000].");
}

/// Calls `visitor(key, field, doc)` for every field of `options`, in the order of the struct.
template <typename Visitor>
void visitOptions(TrackingOptions& options, Visitor&& visitor) {
  visitOrbOptions(options, visitor);
  visitPoseOptions(options, visitor);
  visitKeyframeOptions(options, visitor);
  visitLocalMapOptions(options, visitor);
  visitMapPointOptions(options, visitor);
  visitBackEndOptions(options, visitor);
  visitGlobalBaOptions(options, visitor);
  visitLocalizationOptions(options, visitor);
}

}  // namespace dypho::tracking
