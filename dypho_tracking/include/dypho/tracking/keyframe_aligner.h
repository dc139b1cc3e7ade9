#pragma once
/// \file keyframe_aligner.h
/// Estimates the pose of one frame against the reference keyframe's 3D points.

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/tracking/feature_matcher.h"
#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/keyframe_points.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/pose_optimizer.h"
#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {

/// Result of KeyframeAligner::align.
struct AlignmentResult {
  bool success = false;                                              ///< pose found with >= min_inliers inliers
  Eigen::Isometry3d T_camera_world = Eigen::Isometry3d::Identity();  ///< world -> camera
  /// The camera's velocities during the frame with a rolling shutter (PoseOptimizerResult); zero
  /// without one.
  CameraRates rates;
  /// The exposure the pose refinement weighted the keypoints' blur with (PoseOptimizerResult) [s];
  /// 0 = sharp.
  double blur_exposure_s = 0.0;
  /// The velocities the pose refinement took its blur weights and velocity priors at
  /// (PoseOptimizerResult).
  CameraRates blur_rates;
  std::vector<FeatureMatch> matches;  ///< matches used for the final pose
  std::vector<bool> inliers;          ///< per match: pose inlier
  int num_inliers = 0;                ///< count of inliers
  bool used_pnp = false;              ///< the PnP RANSAC fallback produced the initial pose
  /// `matches[].reference_index` index the `brute_force_reference` passed to align (the tight
  /// pass over the main reference did not replace the PnP result); else the main reference.
  bool matches_refer_to_fallback = false;
  /// Per match, for points on probation (KeyframePoints::verified): +1 it agreed with the pose
  /// (an inlier), -1 it disagreed with the pose of the verified points (verified_first), 0 a
  /// verified point or no verdict. Empty without probation.
  std::vector<std::int8_t> probation;
  /// The pose was estimated from the verified points first (enough of them matched).
  bool verified_first = false;
  std::string message;  ///< why it failed; empty on success
};

/// The pose observation of `match`: its reference point in the world, the frame keypoint's
/// undistorted pixel, pyramid level and measured depth, and with a rolling shutter read out over
/// `readout_s` [s] (> 0) the time of the keypoint's row (rowTimeOffsetS).
PoseObservation observationOf(const FeatureMatch& match, const KeyframePoints& reference, const FrameFeatures& frame,
                              double readout_s = 0.0);

/// How one KeyframeAligner::align runs; the defaults suit a relocalisation or a loop check.
struct AlignmentSettings {
  /// With points on probation (KeyframePoints::verified), estimate the pose from the verified
  /// points first (false: every match carries the pose; the verdicts of the inliers are still
  /// given).
  bool verified_first = true;
  /// The camera's predicted velocities, for a rolling shutter (PoseOptimizer::optimize).
  CameraRates rates_prior;
  /// false skips step 3 (a tracker catching up with the camera: about a quarter of its time per
  /// frame, for precision).
  bool tight_pass = true;
  /// The projection searches apply the ratio test only between candidates at the same pyramid
  /// level for verified points (FeatureMatcher::matchByProjection); for a sharp frame of a moving
  /// camera, where a corner is found again at the next level.
  bool ratio_same_level_only = false;
};

/// Frame-to-keyframe pose estimation in three steps:
///  1. projection-guided matching around the predicted pose (search_radius_px) and Ceres
///     refinement from the prediction; accepted when >= min_inliers inliers remain; otherwise
///     once more over wide_search_radius_px;
///  2. otherwise global brute-force matching + cv::solvePnPRansac (EPnP, undistorted pixels and K)
///     for an initial pose, refined with Ceres on all brute-force matches;
///  3. a second projection pass with the small refine_search_radius_px around the pose of step
///     1/2 collects more matches, and Ceres refines once more (kept when it still has
///     >= min_inliers inliers).
class KeyframeAligner {
 public:
  /// Throws std::invalid_argument when options.validate() does.
  explicit KeyframeAligner(const TrackingOptions& options);

  /// T_camera_world_predicted: prediction (constant velocity or last pose). Adds stage times to
  /// `times` (matching, pnp, refine) when not null. `brute_force_reference` (may be null = use
  /// `reference`): the smaller point set used for the global search + PnP of step 2 (e.g. the
  /// last keyframe's own points while `reference` is the whole local map). Never throws on data.
  AlignmentResult align(const KeyframePoints& reference, const FrameFeatures& frame, const Pinhole& pinhole,
                        const Eigen::Isometry3d& T_camera_world_predicted, TrackingTimesMs* times,
                        const KeyframePoints* brute_force_reference = nullptr,
                        const AlignmentSettings& settings = AlignmentSettings()) const;

 private:
  /// Projection-guided matching within `radius_px` of T_camera_world_predicted, then refine();
  /// true when it found the pose. `num_guided`: the matches found.
  bool guidedPass(const KeyframePoints& reference, const FrameFeatures& frame, const Pinhole& pinhole,
                  const Eigen::Isometry3d& T_camera_world_predicted, double radius_px,
                  const AlignmentSettings& settings, std::size_t* num_guided, AlignmentResult* result,
                  TrackingTimesMs* times) const;
  /// Ceres refinement of `matches` from `T_init` into `result`; true when >= min_inliers.
  bool refine(const KeyframePoints& reference, const FrameFeatures& frame, const Pinhole& pinhole,
              const std::vector<FeatureMatch>& matches, const Eigen::Isometry3d& T_init, bool verified_first,
              const CameraRates& rates_prior, AlignmentResult* result) const;

  TrackingOptions options_;
  FeatureMatcher matcher_;
  PoseOptimizer optimizer_;
};

}  // namespace tracking
}  // namespace dypho
