#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "dypho/tracking/keyframe_selector.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

Eigen::Isometry3d pose(double tx, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(tx, 0, 0);
  return T;
}

/// A well-tracked, slowly moving frame 5 frames after the keyframe, which is not at the origin
/// (so that only the motion relative to the keyframe can matter).
KeyframeQuery calmQuery() {
  KeyframeQuery q;
  q.T_world_keyframe = pose(1.0, 30.0);
  q.T_world_camera = q.T_world_keyframe * pose(0.05, 3.0);
  q.num_inliers = 400;
  q.num_reference_inliers = 500;
  q.frames_since_keyframe = 5;
  q.frame_rotation_deg = 0.5;  // below keyframe_max_frame_rotation_deg = 4
  return q;
}

TEST(KeyframeSelector, SoftTriggers) {
  const KeyframeSelector s{TrackingOptions()};  // 0.10 m, 8 deg, ratio 0.6, 20 frames, 4 deg/frame
  EXPECT_FALSE(s.decide(calmQuery()).is_keyframe);

  KeyframeQuery q = calmQuery();
  q.T_world_camera = q.T_world_keyframe * pose(0.11, 0.0);
  KeyframeDecision d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("translation"), std::string::npos) << d.reason;

  q = calmQuery();
  q.T_world_camera = q.T_world_keyframe * pose(0.0, 8.5);
  d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("rotation"), std::string::npos) << d.reason;

  q = calmQuery();
  q.T_world_camera = q.T_world_keyframe * pose(0.099, 7.9);  // just under both
  EXPECT_FALSE(s.decide(q).is_keyframe);

  q = calmQuery();
  q.num_inliers = 250;  // 250 / 500 = 0.5 < 0.6
  d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("ratio"), std::string::npos) << d.reason;

  q = calmQuery();
  q.frames_since_keyframe = 19;
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.frames_since_keyframe = 20;
  d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("frames"), std::string::npos) << d.reason;
}

TEST(KeyframeSelector, FastRotationPostponesSoftButNotHardTriggers) {
  const KeyframeSelector s{TrackingOptions()};
  KeyframeQuery q = calmQuery();
  q.T_world_camera = q.T_world_keyframe * pose(0.0, 12.0);  // soft trigger: rotation
  q.frame_rotation_deg = 4.5;                               // camera turning fast (default limit 4)
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.frame_rotation_deg = 3.9;
  EXPECT_TRUE(s.decide(q).is_keyframe);

  q = calmQuery();
  q.frame_rotation_deg = 6.0;
  q.num_inliers = 140;  // 140 / 500 = 0.28 < 0.3: hard
  KeyframeDecision d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("hard"), std::string::npos) << d.reason;
  q.num_inliers = 40;
  q.num_reference_inliers = 50;  // ratio fine but 40 < 3 * 15: hard
  EXPECT_TRUE(s.decide(q).is_keyframe);
  q.num_reference_inliers = 0;  // no reference: ratio 0 -> hard
  q.num_inliers = 400;
  EXPECT_TRUE(s.decide(q).is_keyframe);
}

// A still camera's periodic keyframe waits while the static check disputes the pose (its refined
// pose explains more of the reference keyframe's static samples): a keyframe would anchor the
// next frames to a pose moving people may be carrying. The other triggers do not wait, and the
// periodic one waits at most keyframe_max_frames frames more.
TEST(KeyframeSelector, StaticDoubtPostponesOnlyThePeriodicKeyframe) {
  const KeyframeSelector s{TrackingOptions()};  // keyframe_static_doubt 0.02, 20 frames
  KeyframeQuery q = calmQuery();
  q.frames_since_keyframe = 20;
  q.static_doubt = 0.044;  // the stop-and-go case: 0.885 of the samples by features, 0.93 refined
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.static_doubt = 0.019;  // within the noise of an undisputed pose
  EXPECT_TRUE(s.decide(q).is_keyframe);
  q.static_doubt = 0.044;
  q.frames_since_keyframe = 39;
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.frames_since_keyframe = 40;  // 2 * keyframe_max_frames: made anyway
  EXPECT_TRUE(s.decide(q).is_keyframe);

  q = calmQuery();
  q.static_doubt = 0.3;
  q.T_world_camera = q.T_world_keyframe * pose(0.11, 0.0);  // translation
  EXPECT_TRUE(s.decide(q).is_keyframe);
  q = calmQuery();
  q.static_doubt = 0.3;
  q.num_inliers = 250;  // tracked ratio
  EXPECT_TRUE(s.decide(q).is_keyframe);

  TrackingOptions off;
  off.keyframe_static_doubt = 0.0;  // never postponed
  q = calmQuery();
  q.frames_since_keyframe = 20;
  q.static_doubt = 0.3;
  EXPECT_TRUE(KeyframeSelector(off).decide(q).is_keyframe);
}

// While the static check took its dense pose over the pose the matches preferred, the soft
// triggers wait: a keyframe would anchor the next frames and their static checks to a pose that
// its matches and its pixels dispute. Hard triggers do not wait, the soft ones at most until
// 2 * keyframe_max_frames frames since the keyframe, and not at all with the option off.
TEST(KeyframeSelector, DisputedPoseWaitsForSoftButNotHardTriggers) {
  const KeyframeSelector s{TrackingOptions()};  // keyframe_wait_while_disputed, 20 frames
  KeyframeQuery q = calmQuery();
  q.num_inliers = 250;  // tracked ratio 0.5 < 0.6 (the Bonn keyframe: 113 / 229)
  ASSERT_TRUE(s.decide(q).is_keyframe);
  q.pose_disputed = true;
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q = calmQuery();
  q.pose_disputed = true;
  q.T_world_camera = q.T_world_keyframe * pose(0.11, 0.0);  // translation
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.frames_since_keyframe = 39;
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.frames_since_keyframe = 40;  // 2 * keyframe_max_frames: made anyway
  EXPECT_TRUE(s.decide(q).is_keyframe);

  q = calmQuery();
  q.pose_disputed = true;
  q.num_inliers = 140;  // 140 / 500 = 0.28 < 0.3: hard
  KeyframeDecision d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("hard"), std::string::npos) << d.reason;

  TrackingOptions off;
  off.keyframe_wait_while_disputed = false;
  q = calmQuery();
  q.pose_disputed = true;
  q.num_inliers = 250;
  EXPECT_TRUE(KeyframeSelector(off).decide(q).is_keyframe);
}

// With keyframe_sharp_tracked_ratio 0.75 the tracked-ratio trigger fires at 0.75 on a sharp frame
// (< 1 deg/frame) of a moving camera and at 0.6 on a blurred one, and not at 0.75 while the
// tracker is catching up with the camera or the camera is still. By default one ratio (0.6).
TEST(KeyframeSelector, SharpFramesTakeTheHigherTrackedRatio) {
  TrackingOptions sharp_options;
  sharp_options.keyframe_sharp_tracked_ratio = 0.75;
  const KeyframeSelector s{sharp_options};  // 0.75 below 1 deg/frame, else 0.6
  KeyframeQuery q = calmQuery();
  q.num_inliers = 350;  // 350 / 500 = 0.7: between the two ratios
  q.frame_rotation_deg = 0.9;
  KeyframeDecision d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("< 0.75"), std::string::npos) << d.reason;
  q.frame_rotation_deg = 1.1;  // blurred: only the lower ratio
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.num_inliers = 290;  // 0.58 < 0.6
  d = s.decide(q);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("< 0.6"), std::string::npos) << d.reason;

  q = calmQuery();
  q.num_inliers = 350;
  q.frame_rotation_deg = 0.2;
  q.catching_up = true;  // behind the camera: no keyframe for the sharp ratio alone
  EXPECT_FALSE(s.decide(q).is_keyframe);
  q.num_inliers = 290;
  EXPECT_TRUE(s.decide(q).is_keyframe);

  q = calmQuery();
  q.num_inliers = 350;
  q.camera_still = true;  // a still camera sees no new background
  EXPECT_FALSE(s.decide(q).is_keyframe);

  const TrackingOptions one_ratio;  // the default: 0.6 on every frame
  q = calmQuery();
  q.num_inliers = 350;
  EXPECT_FALSE(KeyframeSelector(one_ratio).decide(q).is_keyframe);

  TrackingOptions bad;
  bad.keyframe_sharp_tracked_ratio = 0.5;  // below keyframe_min_tracked_ratio
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
