#pragma once
/// \file tracking_options.h
/// Settings of the RGB-D visual odometry (`RgbdOdometry`) and its parts. One struct, documented
/// defaults, `validate()` and `toString()` (house style, STYLE.md section 9).

#include <string>

namespace dypho {
namespace tracking {

/// All settings of the tracking core. Defaults are tuned on TUM fr1/rpy (640x480, fast rotation).
struct TrackingOptions {
  // --- ORB extraction (OrbExtractor) ---
  /// Keypoints wanted per frame over all pyramid levels [count]; default 1000, range [50, 20000].
  int num_features = 1000;
  /// Scale ratio between consecutive pyramid levels [-]; default 1.2, range (1.0, 2.0].
  double scale_factor = 1.2;
  /// Number of pyramid levels [count]; default 8, range [1, 16].
  int num_levels = 8;
  /// FAST intensity threshold in normal cells [grey levels]; default 20, range [1, 254].
  int fast_threshold = 20;
  /// FAST threshold retried in grid cells where `fast_threshold` found nothing [grey levels];
  /// default 7, range [1, fast_threshold].
  int min_fast_threshold = 7;
  /// Grid cell size on each pyramid level for spreading keypoints [px of that level]; default 30,
  /// range [8, 200].
  int grid_cell_px = 30;
  /// Keypoints keep this distance from every dynamic (masked) pixel, scaled by the level scale, so
  /// that descriptors do not straddle the mask border [px at level 0]; default 4, range [0, 50].
  int mask_border_px = 4;
  /// FAST threshold relaxation under the mask: the threshold is multiplied by
  /// (1 - k * masked_fraction), never below `min_fast_threshold` [-]; default 0.5, range [0, 1];
  /// 0 disables.
  double mask_threshold_relaxation = 0.5;
  /// Paper's relaxed feature test ("Feature Extract") as a third tier, on frames with a non-empty
  /// mask, filling the level's keypoint budget left over by FAST, in grid cells where FAST found
  /// no corner at `min_fast_threshold`: pixel p is a relaxed feature when more than
  /// `relaxed_min_count` of the 16 FAST-ring pixels N satisfy |G(N) - G(p)| > sigma_dy * r, with r
  /// the grey range over the ring and p (the "normalised" grey difference; r must be at least
  /// `fast_threshold`) and sigma_dy = relaxed_sigma0 (1 - relaxed_k * masked_fraction). Unlike
  /// FAST the differing pixels need not form one arc of one sign. Default true: on the Bonn crowd
  /// frames it lowered the ATE from 1.47 to 1.34 cm (detector + flow mask) and from 13.4 to
  /// 6.6 cm (flow mask only; bench/tracking_ablation.sh, docs/journal/benchmarks-2026.md); frames without a
  /// mask are not affected.
  bool relaxed_features = true;
  /// Initial threshold sigma_0 of the relaxed test [fraction of the local grey range];
  /// default 0.3 (paper), range (0, 1].
  double relaxed_sigma0 = 0.3;
  /// k of sigma_dy = sigma_0 (1 - k * masked_fraction) [-]; default 0.9 (paper), range [0, 1].
  double relaxed_k = 0.9;
  /// n_f: a relaxed feature needs more than this many of the 16 ring pixels to differ [count];
  /// default 12 (paper), range [0, 15].
  int relaxed_min_count = 12;

  // --- depth ---
  /// Keypoints with a depth below this are dropped [m]; default 0.1, range (0, max_depth_m).
  double min_depth_m = 0.1;
  /// Keypoints with a depth above this are dropped [m]; default 6.0, range (min_depth_m, 100].
  double max_depth_m = 6.0;

  // --- matching (FeatureMatcher) ---
  /// Largest accepted Hamming distance between two 256-bit ORB descriptors [bits]; default 64,
  /// range [1, 256].
  int max_hamming_distance = 64;
  /// Lowe ratio: best distance must be below ratio_test * second best [-]; default 0.8, (0, 1].
  double ratio_test = 0.8;
  /// Search radius around the constant-velocity prediction, multiplied by the keyframe point's
  /// level scale [px at level 0]; default 15, range [1, 200].
  double search_radius_px = 15.0;
  /// Search radius of the second, refining projection pass around the first pose estimate
  /// [px at level 0]; default 4, range [0.5, 50].
  double refine_search_radius_px = 4.0;
  /// When matching around the prediction fails (a jerk of the hand, dropped frames), it is tried
  /// once more within this radius before the global search [px at level 0]; default 45 (three
  /// search radii; not the default, see below), range [0, 300]; not above search_radius_px =
  /// off (the default: on TUM fr1/rpy it raised the ATE from 3.12 to 4.00 cm whole and from
  /// 5.85 to 6.52 cm with every 15th frame removed: wrong matches within the wide radius pass
  /// the refinement where the global search with PnP found the right pose).
  double wide_search_radius_px = 0.0;
  /// Projection-guided search accepts candidates whose pyramid level differs by at most this
  /// from the keyframe point's level [levels]; default 1 (ORB-SLAM), range [0, num_levels - 1].
  int max_level_difference = 1;
  /// On a sharp frame of a moving camera (the motion model's last step turned it less than this
  /// per frame, and the camera is not still) the projection search applies the ratio test only
  /// between candidates at the same pyramid level for the verified points (point probation), as
  /// ORB-SLAM's SearchByProjection does: a corner found again at the next level is the same
  /// corner, not an ambiguity [deg/frame]; default 0 = off (every candidate competes on every
  /// frame), range [0, 180]; 1.0 = sharp frames. In a crowd (Bonn) the strict test rejected about
  /// a third of the static corners that had a map point within 3 px, and 1.0 gains there (15
  /// frame-removal inputs 1.34 -> 1.16 cm, the graph at 1x 1.31 -> 1.12 cm); it is off because
  /// through the graph fr1/rpy lost (0.74 -> 0.86 cm median of 6 and 9 runs, at the slow frames
  /// of a turn's reversal). On fast turns (blur) the relaxed test lets more wrong matches in, and
  /// for fresh points or a still camera it let people the mask missed drag the pose
  /// (docs/journal/2026-12-04-same-level-ratio.md).
  double ratio_test_same_level_max_rotation_deg = 0.0;

  // --- initial pose (PnP RANSAC, used when the prediction finds too few inliers) ---
  /// RANSAC iterations of cv::solvePnPRansac [count]; default 200, range [10, 100000].
  int ransac_iterations = 200;
  /// RANSAC inlier threshold on undistorted pixels [px]; default 3.0, range (0, 50].
  double ransac_reprojection_px = 3.0;
  /// Fewest pose inliers for a frame to count as tracked [count]; default 15, range [6, 10000].
  int min_inliers = 15;

  // --- pose refinement (PoseOptimizer, Ceres Levenberg-Marquardt) ---
  /// Huber threshold on the whitened reprojection residual (px / sigma_level) [px]; default 2.0,
  /// range (0, 100].
  double huber_px = 2.0;
  /// Levenberg-Marquardt iterations per optimisation round [count]; default 10, range [1, 1000].
  int refine_iterations = 10;
  /// Rounds of optimise-then-reclassify outliers by chi2 (ORB-SLAM style) [count]; default 3,
  /// range [1, 20].
  int outlier_rounds = 3;
  /// chi2 threshold (2 dof) separating inliers from outliers on the whitened residual [-];
  /// default 5.991 (95 %), range (0, 100].
  double chi2_threshold = 5.991;
  /// Virtual stereo baseline b that turns the depth measured in the current frame into a third
  /// residual u - b fx / z (ORB-SLAM RGB-D style; Kinect ~0.075 m) [m]; default 0 = reprojection
  /// only, range [0, 1]. Off by default: on TUM fr1/rpy the colour and depth images are not
  /// exposed at the same instant, and under fast rotation the depth residual raised the ATE from
  /// 2.7 cm to 8-10 cm; the keyframe depth (3D points) is used either way.
  double depth_baseline_m = 0.0;
  /// chi2 threshold (3 dof) for observations with the depth residual [-]; default 7.815 (95 %),
  /// range (0, 100].
  double chi2_threshold_depth = 7.815;
  /// Readout time of the colour camera's rolling shutter: the top row is exposed this long before
  /// the bottom row, the middle row at the frame's stamp [ms]; default -1 = the camera's (the
  /// dataset runner takes `rolling_shutter_readout_ms` from the camera file, config/cameras/; the
  /// ROS nodelet from its `camera_file` when it has one, else it uses a global shutter), 0 =
  /// global shutter, range {-1} or [0, 100].
  /// With a readout, the pose refinement also estimates the camera's angular velocity
  /// during the frame and projects each point with the pose of its keypoint's row, and a new
  /// keyframe's points are made from its keypoints moved to the stamp's view
  /// (compensateRollingShutter). The TUM and Bonn camera files say 30 ms (Kinect v1 / Xtion).
  double rolling_shutter_readout_ms = -1.0;
  /// Prior standard deviation of the angular velocity the pose refinement estimates with a
  /// rolling shutter, about the motion model's rate (zero without one) [rad/s]; default 0.15,
  /// range (0, 100]. A loose prior lets the rate absorb noise on slow frames and the keyframes
  /// made with it (Bonn every 15th frame removed: 13.4 cm with 1; the generator's slow loop with a
  /// rolling shutter: 5.4 cm with 0.3 against 1.6 cm with 0.15); a tight one misses fast turns
  /// (docs/journal/benchmarks-2026.md, section 14).
  double rolling_shutter_rate_sigma_rad_s = 0.15;
  /// The same prior widened on fast turns: its standard deviation is the larger of
  /// rolling_shutter_rate_sigma_rad_s and this ratio times the motion model's rate [-]; default
  /// 0.25, range [0, 10]; 0 = a fixed width. A turn that speeds up by 1-2 deg per frame (fr1/rpy)
  /// changes the rate by 0.5-1 rad/s from one frame to the next, far outside a fixed 0.15 rad/s;
  /// frames slower than 0.6 rad/s keep the tight prior. With 0.25 the fifteen frame-removal inputs
  /// of fr1/rpy went 1.36 -> 1.25 cm and the generator's kinect-fast case 7.96 -> 6.39 cm; Bonn
  /// crowd turns faster than 0.6 rad/s on one frame of 200 (docs/journal/benchmarks-2026.md,
  /// section 23).
  double rolling_shutter_rate_sigma_ratio = 0.25;
  /// Prior standard deviation of the linear velocity estimated with a rolling shutter, about the
  /// motion model's [m/s]; default 0.1, range (0, 100].
  double rolling_shutter_velocity_sigma_m_s = 0.1;
  /// Exposure time of the colour camera, for its motion blur [ms]; default 4, range [0, 100];
  /// 0 = sharp images (off). On a fast turn (motion_blur_min_rate_rad_s) each keypoint's pixel
  /// residual in the pose refinement and its inlier test is weighted by its blur streak: the
  /// image velocity of its point under the motion model's velocities times the exposure; along
  /// the streak the standard deviation grows to sqrt(sigma^2 + L^2 / 12), across it stays sigma
  /// (motion_blur.h). 4 ms is the low end of what the residuals say: a corner found on a streak
  /// scatters along it like one of a 3-5 ms exposure on the generator's 15 ms blur, 6-9 ms on the
  /// TUM and Bonn cameras, whose exposures are not known
  /// (docs/journal/2026-12-06-depth-weight-and-blur.md).
  double motion_blur_exposure_ms = 4.0;
  /// The blur is weighted only on frames whose motion model turns at least this fast [rad/s];
  /// default 0.5, range [0, 100]. People crossing a still camera's view drag its motion model:
  /// weighted by the streaks of that seeming motion, the keypoints give way along it (8 people
  /// before a still camera: 0.52 -> 1.60 cm without this gate). Below 0.5 rad/s (1 deg/frame
  /// at 30 Hz) a 4 ms streak is at most about 1.5 px long with a 525 px lens.
  double motion_blur_min_rate_rad_s = 0.5;
  /// A keyframe keeps the blur its pose refinement weighted (its velocities and exposure), and
  /// local and global bundle adjustment weight its keypoints by the same streaks: a keyframe made
  /// in a fast turn then gives way along its streaks instead of carrying their scatter into its
  /// pose and points. Default true (the generator's fast turns, 15 ms blur, six inputs of 300
  /// and 900 frames: all better, mean 4.60 -> 3.84 cm; TUM fr1/rpy's 150 frames: whole
  /// 0.55 -> 0.59, fifteen frame-removal inputs 0.66 -> 0.69, within their spread; Bonn:
  /// unchanged, it turns slower than motion_blur_min_rate_rad_s).
  bool motion_blur_in_bundle_adjustment = true;

  // --- keyframes (KeyframeSelector) ---
  /// New keyframe when the camera moved more than this since the last keyframe [m]; default 0.10,
  /// range (0, 10].
  double keyframe_translation_m = 0.10;
  /// New keyframe when the camera rotated more than this since the last keyframe [deg]; default 8,
  /// range (0, 180].
  double keyframe_rotation_deg = 8.0;
  /// New keyframe when fewer than this fraction of the keyframe's points are pose inliers [-];
  /// default 0.6, range [0, 1].
  double keyframe_min_tracked_ratio = 0.6;
  /// On a sharp frame (the camera turned less than keyframe_sharp_max_frame_rotation_deg since
  /// the previous frame) the tracked-ratio trigger fires already below this fraction (ORB-SLAM's
  /// RGB-D ratio) when the camera is not still, unless the tracker is in catch-up mode [-];
  /// range [keyframe_min_tracked_ratio, 1]; default 0.6 = keyframe_min_tracked_ratio, one ratio
  /// for every frame. Where people hide the background of a moving camera, an earlier keyframe
  /// adds the background they uncover; on a blurred frame each extra keyframe is one more
  /// blurred, skewed frame that anchors the next ones. 0.75 on sharp frames gains offline on
  /// Bonn (fifteen inputs: flow 1.36 -> 1.20, detector 1.31 -> 1.14 cm), fr1/rpy's window and
  /// the generator's moving crowds, but three of the suite's still-camera crowds lose (e.g. 0.36
  /// -> 0.52 cm), so it is not the default yet (docs/journal/benchmarks-2026.md, section 31).
  double keyframe_sharp_tracked_ratio = 0.6;
  /// A frame counts as sharp for keyframe_sharp_tracked_ratio while the camera turned less than
  /// this since the previous frame [deg/frame]; default 1 (30 deg/s at 30 Hz: a blur streak of
  /// a few pixels in a 10 ms exposure, the dense refinement's limit too), range (0, 180].
  double keyframe_sharp_max_frame_rotation_deg = 1.0;
  /// New keyframe at the latest after this many frames since the last keyframe [frames];
  /// default 20, range [1, 100000].
  int keyframe_max_frames = 20;
  /// The four triggers above are postponed while the camera rotated more than this between the
  /// last two frames: such frames suffer from motion blur, rolling shutter and colour/depth time
  /// offset, and a keyframe anchors every following frame [deg/frame]; default 4 (120 deg/s at
  /// 30 Hz), range (0, 180]. Too low a value starves the map during a long fast turn, until a
  /// hard trigger makes the keyframe at the worst frame: 1.5 held off every soft keyframe through
  /// 85 frames of the generator's fast turns, and the one made then anchored a 4 cm error. The
  /// generator's fast turns (ground truth; sharp / depth noise / 15 ms blur / kinect-fast) went
  /// 1.27 / 1.04 / 5.62 / 11.99 cm with 1.5, 0.47 / 0.40 / 1.84 / 8.81 with 3 and 0.39 / 0.39 /
  /// 1.31 / 9.26 with 4 or more; fr1/rpy's fifteen frame-removal inputs 2.30 cm with 1.5, 2.22
  /// with 2, 1.50 with 3, 1.42 with 4 and 1.69 without the rule
  /// (docs/journal/benchmarks-2026.md, section 20).
  double keyframe_max_frame_rotation_deg = 4.0;
  /// A keyframe is made regardless of the rotation speed when the tracked ratio falls below this
  /// or fewer than 3 * min_inliers inliers remain [-]; default 0.3, range [0, keyframe_min_tracked_ratio].
  double keyframe_hard_tracked_ratio = 0.3;
  /// The periodic keyframe (keyframe_max_frames) is postponed while the static check's refined
  /// pose explains more than this share of the reference keyframe's static samples beyond the
  /// tracked pose without having replaced it: the pose is in doubt (moving matches may be
  /// carrying it, and a keyframe would anchor the next frames and their static checks to it).
  /// At most keyframe_max_frames frames more [-]; default 0.02, range [0, 1]; 0 = never postponed.
  double keyframe_static_doubt = 0.02;
  /// Soft keyframe triggers wait while the static check disputes the tracked pose: it replaced
  /// the feature pose with its dense pose itself because the matches, re-estimated from that
  /// pose, preferred another one (TrackingResult::static_check_disputed). A keyframe anchors the
  /// next frames and their static checks, so one made on a pose that its matches and its pixels
  /// dispute carries that pose on: on Bonn with 10 % of the frames removed at random, a person's
  /// sleeve the YOLOX-nano mask missed pulled one frame's dense pose 5 cm, that frame became a
  /// keyframe on 113 inliers and the next 14 frames' static checks held them 6-8 cm off (2.17 cm
  /// for the whole input, 1.41 cm with the wait). Hard triggers never wait; the others at most
  /// until 2 * keyframe_max_frames frames since the keyframe. Default true.
  bool keyframe_wait_while_disputed = true;
  /// Fewest keypoints with valid depth needed to start (or restart) on a frame [count];
  /// default 100, range [min_inliers, 20000].
  int min_init_features = 100;
  /// After this many consecutive lost frames a new keyframe is started at the last good pose
  /// [frames]; default 5, range [1, 100000].
  int max_lost_frames = 5;

  // --- local map (TrackerMap) ---
  /// Frames are tracked against the map points of the last keyframe and of its this many most
  /// covisible keyframes [count]; default 10, range [0, 100]; 0 = the last keyframe only.
  int local_map_keyframes = 10;
  /// Fewest shared map points for two keyframes to count as covisible [count]; default 15,
  /// range [1, 10000].
  int covisibility_min_shared = 15;
  /// The local map of tracking also takes up to this many keyframes that look at the same part of
  /// the scene as the reference keyframe whether or not they share points with it: optical axes
  /// within local_map_nearby_max_angle_deg and centres within local_map_nearby_max_distance_m,
  /// the closest view first (angle between the axes plus 1 deg per cm between the centres)
  /// [count]; default 10, range [0, 100]; 0 = covisible keyframes only. Under fast turns a
  /// blurred frame matches few points of keyframes blurred in another direction, so each sweep
  /// over a scene made its own keyframes and points and the pose walked off the first sweep's;
  /// the view's keyframes tie every sweep to the first. The generator's kinect-fast case over
  /// 900 frames (seeds 4 and 6) went 7.14 -> 4.46 and 8.82 -> 3.55 cm
  /// (docs/journal/2026-12-05-nearby-keyframes.md).
  int local_map_nearby_keyframes = 10;
  /// Largest angle between the optical axes of the reference keyframe and a keyframe of its view
  /// (local_map_nearby_keyframes) [deg]; default 20 (a third of a Kinect's 62 deg horizontal
  /// field of view), range (0, 180].
  double local_map_nearby_max_angle_deg = 20.0;
  /// Largest distance between the centres of the reference keyframe and a keyframe of its view
  /// [m]; default 0.3, range (0, 100].
  double local_map_nearby_max_distance_m = 0.3;
  /// A map point predicted visible in >= 10 frames but a pose inlier in fewer than this fraction
  /// of them is removed [-]; default 0.25, range [0, 1]; 0 disables culling.
  double cull_min_found_ratio = 0.25;
  /// A map point is removed as moving once it was seen on a dynamic surface in at least this
  /// many tracked frames and in at least as many as it was a pose inlier: its projection fell on
  /// the dynamic mask at its own depth, or it was matched but the depth measured there disagreed
  /// with it [count]; default 2, range [0, 1000]; 0 disables. Removes points of people who stood
  /// still when their keyframe was made and then walk on. Counted on every frame it raised TUM
  /// fr1/rpy from 2.93 to 4.95 cm (the flow mask's halo on a fast-turning camera), hence
  /// `moving_point_still_only`.
  int moving_point_min_hits = 2;
  /// Only sightings while the camera is still count for `moving_point_min_hits` (the tracked
  /// motion of the last frame under 5 mm and 0.2 deg): before a still camera the flow mask has no
  /// ego-motion error, so what it calls dynamic moves; default true.
  bool moving_point_still_only = true;
  /// Depth agreement of a map point with the depth measured at its projection, for the
  /// moving-point test: |z_measured - z_point| below max(this, 0.015 z^2) [m] (z in metres; the
  /// quadratic part follows the RGB-D noise); default 0.05, range (0, 1].
  double moving_point_depth_tolerance_m = 0.05;
  /// Safe start: the first keyframe after a start or a re-initialisation is built before any
  /// mask could judge its pixels (the flow needs a previous frame), so people standing or
  /// walking in it become map points. Its points stay unverified until the next keyframe: one
  /// seen on a dynamic surface (the moving-point test above) in this many tracked frames is
  /// removed, however often it was a pose inlier [count]; default 3, range [0, 1000]; 0 disables.
  /// One or two sightings also remove static points in the flow's halo next to people
  /// (static camera, 8 people from frame 0: 1.97 / 1.43 cm against 0.66 cm with 3).
  int first_keyframe_moving_hits = 3;
  /// Probation of new map points: a point a keyframe created carries the pose only after it
  /// agreed (chi2) with the pose on this many tracked frames; until then, while the camera moves
  /// (the last tracked step above 5 mm or 0.2 deg), each frame's pose is estimated from the
  /// verified points first, and an unverified match that disagrees with that pose is an outlier.
  /// A person the mask missed keeps giving the tracker fresh points while keyframes come every
  /// few frames in a crowd; on a moving camera the moving-point test (moving_point_still_only)
  /// does not look, this catches them once they moved about 2.5 px from where their keyframe saw
  /// them. A still camera has the moving-point test, and there the verified points can include
  /// people the background learnt. Bonn crowd played backwards (people in view from frame 0),
  /// flow mask: 1.63-1.97 cm against 1.98-3.97 cm off (docs/journal/benchmarks-2026.md section 8) [frames];
  /// default 3, range [0, 100]; 0 = off (every point carries the pose at once).
  int point_probation_frames = 3;
  /// An unverified point that disagreed with the verified points' pose on this many frames is
  /// removed as moving (and handed to the mask like the moving-point test's) [count]; default 2,
  /// range [1, 100].
  int point_probation_max_refuted = 2;
  /// Fewest verified matches for the verified-first estimate; with fewer (a start, a new view)
  /// every match carries the pose as without probation [count]; default 40, range
  /// [min_inliers, 10000].
  int point_probation_min_verified = 40;
  /// Dense check of each tracked pose against the reference keyframe's static pixels
  /// (StaticSceneCheck): the feature pose is refined photometrically over the keyframe's
  /// unmasked, textured pixels; when the refined pose explains `static_check_min_gain` more of
  /// them than the feature pose did, a coherent group of moving matches (people the mask missed)
  /// carried the feature pose, and the pose is re-estimated from the matches that agree with the
  /// refined one. Default true.
  bool static_check = true;
  /// Share of the keyframe's static samples the refined pose must explain beyond the feature
  /// pose before it replaces it [-]; default 0.05, range (0, 1].
  double static_check_min_gain = 0.05;
  /// The refinement converges only near its start. Besides the feature pose it may start from
  /// the last frame's pose and from the reference keyframe's (no motion since), whichever of the
  /// three explains most static samples: moving matches that drag the feature pose a little
  /// further on each frame leave the refinement's reach after a few frames (static camera,
  /// 8 people from frame 0, seeds 2 / 3: 1.10 / 0.61 cm against 1.33 / 0.76 cm). Default true.
  bool static_check_other_starts = true;
  /// Working resolution of the check (the refinement also runs at half of it) [-]; default 0.5,
  /// range [0.1, 1].
  double static_check_scale = 0.5;
  /// The check runs only while the camera turned less than this between the last two frames:
  /// motion blur and rolling-shutter skew bias the photometric comparison [deg/frame];
  /// default 0.5, range (0, 180].
  double static_check_max_frame_rotation_deg = 0.5;
  /// Dense refinement of every tracked frame (DenseRgbdAligner): after the feature pose (and the
  /// static check), the frame is aligned to its reference keyframe by photometric and depth
  /// residuals over the static pixels, coarse to fine, with t-distribution weights and depth
  /// residuals weighted by the depth noise (dense_depth_sigma_per_m2). The feature pose enters as
  /// a prior with its information (dense_feature_prior_weight), so features and pixels form one
  /// cost. Skipped in catch-up mode. Default false: over the shared sequences whole, with every
  /// 15th frame removed and with 10 % removed at random (bench/precision_ablation.sh, section
  /// 21), it lost everywhere at the current tracker: fr1/rpy 1.54 -> 1.62, Bonn flow 1.49 ->
  /// 1.84, Bonn detector 1.35 -> 1.42, the generator's kinect-fast case 8.01 -> 10.24 cm.
  bool dense_refinement = false;
  /// Finest working resolution of the dense refinement [-]; default 0.5, range [0.1, 1].
  double dense_scale = 0.5;
  /// Pyramid levels of the dense refinement, each half the previous [count]; default 3, range [1, 5].
  int dense_levels = 3;
  /// Gauss-Newton iterations per level [count]; default 8, range [1, 50].
  int dense_iterations = 8;
  /// Weight of the feature pose's information (its inliers' reprojection residuals) in the
  /// dense cost [-]; default 1.0, range [0, 1e6]; 0 = dense residuals alone.
  double dense_feature_prior_weight = 1.0;
  /// Depth noise of the sensor, sigma(z) = k z^2, that weights the dense depth residuals [1/m];
  /// default 1.425e-3 (Kinect v1, Khoshelham and Elberink 2012), range (0, 0.1].
  double dense_depth_sigma_per_m2 = 1.425e-3;
  /// A dense correction larger than this (translation [m] or rotation [deg]) away from the
  /// feature pose is not taken: the alignment left its basin; defaults 0.05 m and 2 deg.
  double dense_max_correction_m = 0.05;
  double dense_max_correction_deg = 2.0;
  /// The dense refinement runs only while the camera turned less than this per frame interval:
  /// under faster turns motion blur and rolling-shutter skew bias the pixels more than the
  /// features [deg/frame]; default 1.0, range (0, 180].
  double dense_max_frame_rotation_deg = 1.0;
  /// After each keyframe, a keyframe of its local map (not the oldest) is removed when at least
  /// this fraction of its map points is seen by >= 3 other keyframes at the same or a finer scale
  /// (ORB-SLAM's rule; bounds the map while the camera stays in known places) [-]; default 0.9,
  /// range [0, 1]; 0 keeps every keyframe.
  double keyframe_cull_redundant_ratio = 0.9;
  /// Fuse step after each keyframe (keyframe_point_fuser.h): its points are matched in this
  /// many of its most covisible keyframes and theirs in it; duplicates are merged, features
  /// without a point observe the one they match [count]; range [0, 50]; default 0 = off, by
  /// measurement: with 10, means over the whole window, every 15th and 10 % of the frames removed
  /// went fr1/rpy flow 4.29 -> 8.78 cm, no mask 4.45 -> 4.56, Bonn flow 1.85 -> 1.72, Bonn
  /// detector 1.90 -> 1.97, generator fast turns 1.79 -> 1.82 cm
  /// (docs/journal/benchmarks-2026.md section 13). Only trusted points are fused (past probation,
  /// never on a moving surface); means of fifteen frame-removal inputs with 10: fr1/rpy 2.30 ->
  /// 1.96, Bonn flow 1.39 -> 1.37, detector 1.35 -> 1.33, but whole windows fr1 1.61 -> 1.76 and
  /// Bonn flow 1.31 -> 1.66 cm, and two of the generator's tests fail (section 18).
  int fuse_keyframes = 0;
  /// Search radius of the fuse step around a point's projection, times its level scale [px at
  /// level 0]; default 3 (ORB-SLAM), range (0, 50].
  double fuse_radius_px = 3.0;
  /// Largest Hamming distance of a fused match [bits]; default 50 (ORB-SLAM's TH_LOW), range
  /// [1, 256].
  int fuse_max_hamming_distance = 50;
  /// Largest difference between a feature's measured depth and the projected point's, relative
  /// to that depth [-]; default 0.05, range (0, 1].
  double fuse_max_depth_ratio = 0.05;

  // --- local bundle adjustment (LocalBundleAdjuster), synchronous after each keyframe ---
  /// Keyframes whose poses local BA optimises: the new one and its most covisible ones [count];
  /// default 5, range [0, 50]; 0 disables local BA.
  int local_ba_keyframes = 5;
  /// Levenberg-Marquardt iterations of each of the two local BA rounds [count]; default 5,
  /// range [1, 100].
  int local_ba_iterations = 5;
  /// Virtual stereo baseline of the depth term of local BA (BaRgbdError's third row:
  /// b f_x (1/z - 1/z_meas), same sigma as the pixels); it fixes the metric scale [m]; default
  /// 0.08 (Kinect-like), range [0, 1]; 0 = reprojection only (then the scale is held only by the
  /// fixed keyframes).
  double local_ba_depth_baseline_m = 0.08;
  /// Most keyframes held fixed in local BA (those seeing the window's points most) [count];
  /// default 10, range [1, 100].
  int local_ba_max_fixed_keyframes = 10;
  /// Local BA of a new keyframe runs on its own thread on a copy of its window while the next
  /// frames are tracked; its result, with the point and keyframe culling and the loop detection
  /// that follow it, is applied at the start of the frame this many frames later, or before the
  /// next keyframe when that comes first, waiting for it when it has not finished [frames];
  /// default 0, range [0, 30]; 0 = at once, inside the keyframe's frame. Where it is applied
  /// depends on frame counts only, so runs stay repeatable.
  int local_ba_async_frames = 0;

  // --- catching up with the camera (live graph; the offline runner never waits) ---
  /// A frame is tracked in catch-up mode when at least this many frames wait behind it (the live
  /// graph fell behind the camera, e.g. on a loaded machine): a keyframe made then skips its local
  /// BA, its heaviest work (ORB-SLAM's local mapping aborts its BA when keyframes queue up; the
  /// next keyframe's window covers this one), and every frame skips the aligner's tight second
  /// projection pass (KeyframeAligner::align step 3, about a quarter of the tracking thread's
  /// time). The tracker then catches up instead of dropping frames. The static check still runs:
  /// without it a crowd can carry the pose [frames];
  /// default 4 (about 130 ms behind at 30 Hz), range [0, 1000]; 0 = never.
  int catch_up_frames_waiting = 4;

  // --- relocalisation (Relocalizer) ---
  /// Keyframes tried per lost frame, newest first then spread over the map [count]; default 20,
  /// range [1, 10000].
  int relocalization_max_keyframes = 20;
  /// Fewest pose inliers to accept a relocalisation [count]; default 30, range [min_inliers, 10000].
  int relocalization_min_inliers = 30;

  // --- loop closure (LoopDetector, LoopCloser, PoseGraphOptimizer) ---
  /// Detect and close loops at each new keyframe; default true.
  bool loop_closure = true;
  /// Candidates are at least this many keyframes older than the new one; also the pause after a
  /// closed loop [keyframes]; default 20, range [2, 100000].
  int loop_min_keyframe_gap = 20;
  /// Candidates' camera centre within this distance of the new keyframe's (drift must stay below
  /// it) [m]; default 1.0, range (0, 100].
  double loop_search_radius_m = 1.0;
  /// Candidates' optical axis within this angle of the new keyframe's [deg]; default 45,
  /// range (0, 180].
  double loop_max_angle_deg = 45.0;
  /// Candidates verified per keyframe, nearest first [count]; default 3, range [1, 100].
  int loop_max_candidates = 3;
  /// Fewest pose inliers to accept a loop [count]; default 50, range [min_inliers, 10000].
  int loop_min_inliers = 50;
  /// Weight of the loop edge relative to the odometry/covisibility edges [-]; default 1,
  /// range (0, 1000].
  double loop_edge_weight = 1.0;
  /// Covisibility edges of the pose graph need this many shared points [count]; default 100,
  /// range [1, 100000].
  int pose_graph_min_shared = 100;
  /// Rotation standard deviation of a pose-graph edge [deg]; default 0.5, range (0, 90].
  double pose_graph_sigma_rot_deg = 0.5;
  /// Translation standard deviation of a pose-graph edge [m]; default 0.01, range (0, 10].
  double pose_graph_sigma_trans_m = 0.01;
  /// Levenberg-Marquardt iterations of the pose graph [count]; default 20, range [1, 1000].
  int pose_graph_iterations = 20;

  /// Throws std::invalid_argument naming the first field out of range and its allowed range.
  void validate() const;
  /// One "name: value" line per field, in declaration order.
  std::string toString() const;
  // --- corrections handed to mapping ---
  /// A keyframe moved by local BA or loop closure by more than this is reported in
  /// TrackingResult::corrected_keyframes [m]; default 0.001, range [0, 1].
  double correction_min_translation_m = 0.001;
  /// The same for rotation [rad]; default 0.001 (0.057 deg), range [0, 1].
  double correction_min_rotation_rad = 0.001;

  // --- global bundle adjustment (GlobalBundleAdjuster): every keyframe and map point ---
  /// Run a global BA right after each closed loop (after the pose graph), synchronously on the
  /// tracking thread; default false: on the 600-frame synthetic loop (82 keyframes) it took
  /// 1.4-2.7 s on the shared 2-core VM (one thread), far beyond a frame's 33 ms, and the final trajectory was no better
  /// (0.56 cm with it, 0.54 cm without, both with global_ba_at_end).
  bool global_ba_after_loop = false;
  /// Run a global BA at the end of a run (RgbdOdometry::finishRun: the offline runner before it
  /// writes trajectory.txt, the tracking nodelet at shutdown before it saves), after which the
  /// saved trajectory follows the adjusted keyframes; default true: with the keyframe-pair prior
  /// (global_ba_prior_sigma_*) it gains on the means of the shared windows' fifteen
  /// frame-removal inputs (fr1/rpy 1.42 -> 1.36, Bonn crowd flow 1.37 -> 1.34, detector 1.35 ->
  /// 1.31 cm) and on their worst input. 0.05-0.4 s on the real windows (16-33 keyframes), 1.3-2.3
  /// s on the synthetic loop (82), bounded by global_ba_max_seconds.
  bool global_ba_at_end = true;
  /// Levenberg-Marquardt iterations of each of the two global BA rounds (outliers removed in
  /// between) [count]; default 10 (ORB-SLAM's global BA), range [1, 100].
  int global_ba_iterations = 10;
  /// Global BA holds each keyframe near its pose relative to the keyframe before it (by id), as
  /// the map had it before the BA: a prior of this standard deviation on their relative rotation
  /// [deg] (newBaRelativePoseError); default 0.5: the pose graph's edge sigma
  /// (pose_graph_sigma_rot_deg), the error it assigns a tracked relative pose; range [0, 90], 0
  /// with global_ba_prior_sigma_m 0: no prior. Looser priors (2 deg / 4 cm) gave the generator's
  /// kinect-fast case back the global BA's gain (means 8.01 without global BA, 6.80 without a
  /// prior, 7.96 at 0.5 deg / 1 cm, 6.89 at 2 deg / 4 cm) but not the Bonn crowd's fifteen inputs
  /// (flow mean 1.37 at 2 deg / 4 cm, 1.34 at 0.5 deg / 1 cm). A keyframe whose multi-view points
  /// lie in a small patch of the image has a direction that its points hardly see (a sideways
  /// shift against a turn); without the prior, global BA moved such a keyframe 12 cm on Bonn crowd
  /// with every 15th frame removed (ATE 1.41 -> 3.97 cm). A well-seen keyframe's hundreds of
  /// observations outweigh it by far.
  double global_ba_prior_sigma_deg = 0.5;
  /// The same prior on their relative translation [m]; default 0.01 (the pose graph's,
  /// pose_graph_sigma_trans_m), range [0, 10].
  double global_ba_prior_sigma_m = 0.01;
  /// Wall-time budget of one global BA, both rounds together [s] (each round stops with its best
  /// solution so far when its half is spent); default 4: the tracking nodelet runs the final
  /// global BA in its shutdown, before it saves, and roslaunch escalates to SIGTERM 15 s after
  /// its SIGINT. Range [0.1, 3600].
  double global_ba_max_seconds = 4.0;
  /// After the final global BA, each tracked frame's pose is optimised once more against the
  /// final positions of the map points it matched (FinalFrameRefiner: the tracking estimator, from
  /// its saved pose, with its own keypoints, depths and velocities); the saved trajectory takes
  /// it when at least min_inliers inliers remain. A frame was tracked against points that the
  /// later keyframes' local BAs and the global BA refined since; its pose relative to its keyframe
  /// does not follow them. A pose the static check or the dense refinement set is kept as it is
  /// (it came from pixels, not from its matches). Default false: it gains on static scenes (TUM
  /// fr1/rpy 0.59 -> 0.56 cm, every 15th frame removed 0.76 -> 0.75, no mask 0.65 -> 0.63) and
  /// loses a little in a crowd (Bonn crowd window 1.02 -> 1.04 cm, YOLOX-nano 0.83 -> 0.85; every
  /// frame refined lost more there); on for a scene without people
  /// (docs/journal/benchmarks-2026.md section 61).
  bool final_frame_refinement = false;
  /// The newest this many tracked frames keep their inlier observations for the final refinement
  /// (about 10 KB per frame); older frames keep their tracked pose [frames]; default 1800 (one
  /// minute at 30 Hz, about 18 MB; refining them takes a few seconds of the shutdown), range
  /// [0, 1000000]; 0 = none kept.
  int final_frame_refinement_max_frames = 1800;
  /// Only frames whose mask called at most this share of the image dynamic are refined: with
  /// movers in view, points on people who stood still may be among the inliers, and the tracked
  /// pose (checked by the static check) is kept [-]; default 0.05, range [0, 1]; 1 = every frame.
  /// Every frame refined gained on TUM fr1/rpy and the generator's fast turns but lost on five of
  /// the Bonn crowd window's six inputs (docs/journal/benchmarks-2026.md section 61).
  double final_frame_refinement_max_masked_fraction = 0.05;
  /// Wall-time budget of the final refinement [s]: it goes from the newest frame back, and the
  /// frames it did not reach keep their tracked pose; default 2 (about 1000 frames on one core of
  /// the 2-core VM; the tracking nodelet refines inside its shutdown, after the final global BA),
  /// range [0.1, 3600].
  double final_frame_refinement_max_seconds = 2.0;
  /// The saved trajectory (trajectory.txt; not the poses published at frame time): each frame's
  /// position is replaced by the straight line fitted in time through the positions of its
  /// segment within +- this many seconds (smoothPositions, trajectory_recorder.h) [s]; default
  /// 0.075 (+-2 frames at 30 Hz). The per-frame translation noise is white (fr1/rpy: a second
  /// difference of 15 mm rms frame to frame where the ground truth has 0.9 mm), a camera's motion
  /// smooth: the window divides the noise by about sqrt(5) while a hand-held acceleration of
  /// 1 m/s^2 is followed to about 1 mm. Rotations are kept. 0 = off; range [0, 1].
  double trajectory_smoothing_s = 0.075;
  /// The same fit made robust: a position farther from its fit than this many sigma (sigma from
  /// the median distance of all positions to their fits) weighs less, as 1 / distance (Huber),
  /// in three more fits [-]; default 3: Gaussian noise is fitted as before (3 sigma is beyond 99 %
  /// of a 3-D Gaussian's lengths), while a frame centimetres off (a blurred frame in a fast turn)
  /// no longer pulls its neighbours. fr1/rpy's fifteen frame-removal inputs 0.73 -> 0.70 cm (14 of
  /// 15 lower), Bonn's 1.16 unchanged. 0 = plain least squares; range [0, 100].
  double trajectory_smoothing_outlier_sigmas = 3.0;

  // --- localisation in a loaded map (RgbdOdometry::restoreSession) ---
  /// Localise only: track against the map a saved session brought (restoreSession) without
  /// changing it: no keyframes, no map points, no point culling, no local or global BA, no loop
  /// closure; the reference keyframe moves to the one that sees most of the frame's inliers. A
  /// lost frame searches the map by relocalisation, never a new segment. Without a loaded map
  /// nothing is tracked (kNotInitialized, the message says to restore a session). Default false.
  bool localization_only = false;
  /// Localisation only: a pose (tracked or relocalised) farther than this from the
  /// constant-velocity prediction (the last good pose after a loss; the limit grows by itself
  /// per frame lost since) is refused as lost unless it has localization_confident_inliers
  /// inliers; a wrong pose would also spoil the next prediction. Not applied while a restored
  /// map is searched (no prediction yet) [m]; default 0.2, range (0, 100].
  double localization_max_jump_m = 0.2;
  /// The same for the rotation [deg]; default 5, range (0, 180].
  double localization_max_jump_deg = 5.0;
  /// Inliers from which a pose that strays from the prediction is still accepted (the prediction
  /// was wrong, not the pose) [count]; default 200, range [min_inliers, 100000].
  int localization_confident_inliers = 200;
};

}  // namespace tracking
}  // namespace dypho
