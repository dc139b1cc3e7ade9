#pragma once
/// \file keyframe_selector.h
/// Decides whether a tracked frame becomes a new keyframe.

#include <string>

#include <Eigen/Geometry>

#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// Outcome of KeyframeSelector::decide.
struct KeyframeDecision {
  bool is_keyframe = false;  ///< make this frame a keyframe
  std::string reason;        ///< which criterion fired ("translation 0.12 m > 0.10 m"), else empty
};

/// A frame becomes a keyframe when any of these holds (checked in this order):
///  1. translation since the keyframe > keyframe_translation_m;
///  2. rotation angle since the keyframe > keyframe_rotation_deg;
///  3. tracked ratio = num_inliers / num_reference_inliers < keyframe_min_tracked_ratio, where
///     num_reference_inliers is the inlier count of the first frame tracked against this keyframe
///     (the points that are trackable at all; ORB-SLAM similarly compares with the keyframe's
///     tracked map points, not with all its keypoints, since typically only 30-50 % of the ORB
///     keypoints of a frame are re-detected and matched in the next one);
///  4. frames_since_keyframe >= keyframe_max_frames.
class KeyframeSelector {
 public:
  /// Uses the keyframe_* fields.
  explicit KeyframeSelector(const TrackingOptions& options);

  /// T_world_keyframe / T_world_camera: poses of the last keyframe and of the current frame;
  /// num_inliers: pose inliers of the current frame against that keyframe; num_reference_inliers:
  /// see criterion 3 (<= 0 -> ratio treated as 0); frames_since_keyframe: 1 for the frame right
  /// after the keyframe.
  KeyframeDecision decide(const Eigen::Isometry3d& T_world_keyframe,
                          const Eigen::Isometry3d& T_world_camera, int num_inliers,
                          int num_reference_inliers, int frames_since_keyframe) const;

 private:
  TrackingOptions options_;
};

}  // namespace tracking
}  // namespace dypho
