#include <gtest/gtest.h>

#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/trajectory_recorder.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

Eigen::Isometry3d pose(double x, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, 0.1, 0.0);
  return T;
}

TrackingResult tracked(Timestamp stamp, std::int64_t reference, const Eigen::Isometry3d& T_world_ref,
                       const Eigen::Isometry3d& T_world_camera) {
  TrackingResult r;
  r.stamp_ns = stamp;
  r.state = TrackingState::kOk;
  r.reference_keyframe_id = reference;
  r.T_world_camera = T_world_camera;
  r.T_reference_camera = T_world_ref.inverse() * T_world_camera;
  return r;
}

TEST(TrajectoryRecorder, FramesFollowTheLaterCorrectionOfTheirKeyframe) {
  TrackerMap map{TrackingOptions()};
  MapKeyframe kf0, kf1;
  kf0.id = 0;
  kf0.T_world_camera = pose(0.0, 0.0);
  kf1.id = 1;
  kf1.T_world_camera = pose(1.0, 0.2);
  map.addKeyframe(kf0);
  map.addKeyframe(kf1);

  TrajectoryRecorder recorder;
  const Eigen::Isometry3d frame_a = pose(0.3, 0.05), frame_b = pose(1.2, 0.25);
  recorder.add(tracked(10, 0, kf0.T_world_camera, frame_a));
  TrackingResult lost = tracked(15, 0, kf0.T_world_camera, frame_a);
  lost.state = TrackingState::kLost;  // not tracked: keeps its published pose
  recorder.add(lost);
  recorder.add(tracked(20, 1, kf1.T_world_camera, frame_b));
  ASSERT_EQ(recorder.records().size(), 3u);

  // Before any correction the final poses equal the online ones.
  auto final_poses = recorder.finalPoses(map);
  ASSERT_EQ(final_poses.size(), 3u);
  EXPECT_TRUE(final_poses[0].second.isApprox(frame_a, 1e-12));
  EXPECT_TRUE(final_poses[2].second.isApprox(frame_b, 1e-12));

  // Local BA / a loop closure moves both keyframes: the tracked frames move rigidly with their
  // keyframe, the lost frame keeps what was published.
  const Eigen::Isometry3d correction0 = pose(0.02, 0.01), correction1 = pose(-0.05, -0.02);
  map.applyKeyframePoses({{0, correction0 * kf0.T_world_camera}, {1, correction1 * kf1.T_world_camera}});
  final_poses = recorder.finalPoses(map);
  EXPECT_TRUE(final_poses[0].second.isApprox(correction0 * frame_a, 1e-12));
  EXPECT_TRUE(final_poses[1].second.isApprox(frame_a, 1e-12));
  EXPECT_TRUE(final_poses[2].second.isApprox(correction1 * frame_b, 1e-12));
  EXPECT_EQ(final_poses[2].first, 20);
  // The online poses are what was published.
  EXPECT_TRUE(recorder.onlinePoses()[2].second.isApprox(frame_b, 1e-12));

  // Keyframe 1 removed as redundant: its frames follow the keyframe it was attached to.
  ASSERT_TRUE(map.removeKeyframe(1));
  const Eigen::Isometry3d correction0b = pose(0.01, -0.03);
  const Eigen::Isometry3d T_world_0 = map.keyframe(0)->T_world_camera;
  map.applyKeyframePoses({{0, correction0b * T_world_0}});
  final_poses = recorder.finalPoses(map);
  EXPECT_TRUE(final_poses[2].second.isApprox(correction0b * correction1 * frame_b, 1e-12));

  // After a reset (keyframes gone) the online pose is kept.
  map.clear();
  final_poses = recorder.finalPoses(map);
  EXPECT_TRUE(final_poses[2].second.isApprox(frame_b, 1e-12));
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
