#pragma once
/// \file keyframe_selector.h
/// Decides whether a tracked frame becomes a new keyframe.

#include <string>

#include <Eigen/Geometry>

#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// What the selector looks at for one tracked frame.
struct KeyframeQuery {
  Eigen::Isometry3d T_world_keyframe = Eigen::Isometry3d::Identity();  ///< last keyframe pose
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();    ///< current frame pose
  int num_inliers = 0;  ///< pose inliers of the current frame against the keyframe [count]
  /// Inliers of the first frame tracked against this keyframe: the points that are trackable at
  /// all [count]; <= 0 -> tracked ratio 0.
  int num_reference_inliers = 0;
  int frames_since_keyframe = 0;  ///< 1 for the frame right after the keyframe [frames]
  double frame_rotation_deg = 0;  ///< rotation between the previous and this frame [deg]
  /// Share of the reference keyframe's static samples the static check's refined pose explains
  /// beyond the tracked pose, when it did not replace it (TrackingResult::static_check_doubt) [-].
  double static_doubt = 0;
  /// The tracker is behind the camera (catch-up mode): no keyframe for the sharp ratio alone.
  bool catching_up = false;
  /// The last frame-to-frame motion was under 5 mm and 0.2 deg (RgbdOdometry::cameraStill): a
  /// still camera sees no new background, so no keyframe for the sharp ratio alone either.
  bool camera_still = false;
  /// The static check took its dense pose over the pose the matches preferred
  /// (TrackingResult::static_check_disputed).
  bool pose_disputed = false;
};

/// Outcome of KeyframeSelector::decide.
struct KeyframeDecision {
  bool is_keyframe = false;  ///< make this frame a keyframe
  std::string reason;        ///< which criterion fired ("translation 0.12 m > 0.10 m"), else empty
};

/// Keyframe policy.
///
/// Hard triggers (always honoured): tracked ratio = num_inliers / num_reference_inliers below
/// keyframe_hard_tracked_ratio, or fewer than 3 * min_inliers inliers.
///
/// Soft triggers, checked in this order and postponed while frame_rotation_deg >
/// keyframe_max_frame_rotation_deg (fast-moving frames make poor keyframes), and while
/// pose_disputed (keyframe_wait_while_disputed) until frames_since_keyframe reaches
/// 2 * keyframe_max_frames (a keyframe anchors the next frames to its pose):
///  1. translation since the keyframe > keyframe_translation_m;
///  2. rotation angle since the keyframe > keyframe_rotation_deg;
///  3. tracked ratio < keyframe_min_tracked_ratio (the reference is the first tracked frame, like
///     ORB-SLAM compares with the keyframe's tracked map points, because typically only 30-50 % of
///     a frame's ORB keypoints are re-detected and matched in the next one); below
///     keyframe_sharp_tracked_ratio already on a sharp frame (frame_rotation_deg <
///     keyframe_sharp_max_frame_rotation_deg) of a moving camera (not camera_still) when not
///     catching_up (ORB-SLAM likewise takes its ratio keyframes only while local mapping is idle);
///  4. frames_since_keyframe >= keyframe_max_frames; postponed while static_doubt >
///     keyframe_static_doubt, up to 2 * keyframe_max_frames (a still camera's periodic keyframe
///     waits for a pose the static scene does not dispute).
class KeyframeSelector {
 public:
  /// Uses the keyframe_* fields and min_inliers.
  explicit KeyframeSelector(const TrackingOptions& options);

  /// See the class comment.
  KeyframeDecision decide(const KeyframeQuery& query) const;

 private:
  /// keyframe_sharp_tracked_ratio on a sharp frame outside catch-up mode, else
  /// keyframe_min_tracked_ratio.
  double minTrackedRatio(const KeyframeQuery& q) const;

  TrackingOptions options_;
};

}  // namespace tracking
}  // namespace dypho
