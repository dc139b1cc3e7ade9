#pragma once
/// \file feature_matcher.h
/// Matches keyframe points to frame keypoints by ORB descriptor.

#include <vector>

#include <Eigen/Geometry>

#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/keyframe_points.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// One keyframe-point to frame-keypoint correspondence.
struct FeatureMatch {
  int reference_index = -1;  ///< index into KeyframePoints
  int frame_index = -1;      ///< index into FrameFeatures
  int distance = 0;          ///< Hamming distance [bits]
};

/// Descriptor matching, one-to-one (each frame keypoint is used by at most one match, the one with
/// the smallest distance). Both searches finish with ORB-SLAM's rotation-consistency check: the
/// keypoint angle differences are binned in 30 bins of 12 deg and only matches in the three most
/// populated bins are kept (second and third only when they hold >= 10 % of the first).
class FeatureMatcher {
 public:
  /// Uses max_hamming_distance, ratio_test, max_level_difference, scale_factor.
  explicit FeatureMatcher(const TrackingOptions& options);

  /// Projection-guided search: projects every reference point with `T_camera_world` and looks
  /// for frame keypoints (undistorted coordinates) within radius_px * scale_factor^level of the
  /// projection, with a level at most `max_level_difference` away. Accepts the best candidate when
  /// its distance is <= max_hamming_distance and < ratio_test * second best.
  /// `ratio_same_level_only`: for a verified reference point (KeyframePoints::verified; none when
  /// that is empty) the second best competes only when it lies at the best's pyramid level
  /// (ORB-SLAM's SearchByProjection): a corner found again at the next level is the same corner,
  /// not an ambiguity (false: every candidate competes).
  std::vector<FeatureMatch> matchByProjection(const KeyframePoints& reference, const FrameFeatures& frame,
                                              const Eigen::Isometry3d& T_camera_world, const Pinhole& pinhole,
                                              double radius_px, bool ratio_same_level_only = false) const;

  /// Global brute-force Hamming search (no pose needed): k = 2 nearest neighbours with the ratio
  /// test, distance <= max_hamming_distance, and a mutual (cross) check.
  std::vector<FeatureMatch> matchBruteForce(const KeyframePoints& reference, const FrameFeatures& frame) const;

 private:
  TrackingOptions options_;
};

/// Keeps only matches whose angle difference falls in the three dominant 12-degree bins.
std::vector<FeatureMatch> filterByRotationConsistency(const std::vector<FeatureMatch>& matches,
                                                      const KeyframePoints& reference, const FrameFeatures& frame);

}  // namespace tracking
}  // namespace dypho
