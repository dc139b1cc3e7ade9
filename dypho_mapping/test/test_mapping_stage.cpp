/// MappingStage: keyframe corrections in order with the keyframes, R_d at the predicted pose, and
/// R_d and the viewers' views rendered side by side.

#include <memory>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "dypho/mapping/mapping_stage.h"
#include "plane_keyframe.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

Keyframe planeKeyframe(std::int64_t id, const Eigen::Isometry3d& T_world_camera) {
  return test::texturedPlaneKeyframe(id, T_world_camera, 160, 120, 130.0, 10);
}

GaussianMapperOptions smallOptions() { return test::smallMapperOptions(); }

// The mapping stage re-anchors a keyframe's Gaussians when tracking corrects it (local BA or loop
// closure), in order with the keyframes: a correction sent right after its keyframe, while that
// keyframe still waits in the worker's queue, still reaches it; and R_d is rendered from a
// snapshot of the map at the predicted pose of the next frame.
TEST(MappingStage, CorrectionMovesTheKeyframesGaussiansInOrder) {
  MappingOptions options;
  options.gaussian = smallOptions();
  options.gaussian.iterations_per_keyframe = 0;  // no training: positions change only by corrections
  MappingStage stage(options, MappingMode::kDeterministic);
  ASSERT_TRUE(stage.addKeyframe(std::make_shared<Keyframe>(planeKeyframe(7, Eigen::Isometry3d::Identity()))));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.25, -0.1, 0.0);
  T.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  stage.correctKeyframes({{7, T}, {99, T}});  // 99: unknown, ignored
  stage.gaussians().waitUntilIdle();
  const MapSnapshot snapshot = stage.gaussians().latestSnapshot();
  ASSERT_TRUE(snapshot.map != nullptr);
  const std::vector<GaussianCentre> moved = stage.gaussianCentres();
  ASSERT_EQ(moved.size(), snapshot.map->size());
  ASSERT_GT(moved.size(), 100u);
  EXPECT_EQ(stage.stats().gaussians.corrected_keyframes, 1u);
  // The snapshot was taken after the keyframe's job, before the correction: p_moved = T p_before.
  const float* p = snapshot.map->data(kParamPosition);
  for (std::size_t i = 0; i < moved.size(); ++i) {
    const Eigen::Vector3d expected = T * Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    ASSERT_NEAR(moved[i].x, expected.x(), 1e-5) << i;
    ASSERT_NEAR(moved[i].y, expected.y(), 1e-5) << i;
    ASSERT_NEAR(moved[i].z, expected.z(), 1e-5) << i;
  }
  const KeyframePoseCorrections poses = stage.gaussians().keyframePoses();
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_TRUE(poses[0].second.isApprox(T, 1e-12));
}

TEST(MappingStage, PredictedDepthNeedsAVelocityAndAMap) {
  MappingOptions options;
  options.gaussian = smallOptions();
  options.gaussian.iterations_per_keyframe = 5;
  MappingStage stage(options, MappingMode::kLive);
  const Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
  const CameraIntrinsics camera = kf.frame.camera;
  const Timestamp dt = 33'333'333;
  stage.observePose({0, Eigen::Isometry3d::Identity(), true, false});
  EXPECT_TRUE(stage.predictedDepth(dt, camera).empty());  // no velocity yet
  stage.observePose({dt, Eigen::Isometry3d::Identity(), true, false});
  EXPECT_TRUE(stage.predictedDepth(2 * dt, camera).empty());  // no map yet
  stage.addKeyframe(std::make_shared<Keyframe>(kf));
  stage.gaussians().waitUntilIdle();
  ASSERT_TRUE(stage.expectedNextStamp().has_value());
  EXPECT_EQ(*stage.expectedNextStamp(), 2 * dt);
  const cv::Mat depth = stage.predictedDepth(2 * dt, camera);
  ASSERT_FALSE(depth.empty());
  EXPECT_EQ(depth.type(), CV_32FC1);
  EXPECT_GT(cv::countNonZero(depth > 0.f), static_cast<int>(depth.total() / 2));  // the plane fills the view
  // A jump (e.g. loop closure) leaves no velocity: no prediction across it.
  stage.observePose({3 * dt, Eigen::Isometry3d::Identity(), true, true});
  EXPECT_TRUE(stage.predictedDepth(4 * dt, camera).empty());
}

// R_d and the views for viewers render with renderers of their own (a view render must not keep
// the mask waiting): rendered at once from two threads, each gives the same bits as alone.
TEST(MappingStage, PredictedDepthAndViewsRenderSideBySide) {
  MappingOptions options;
  options.gaussian = smallOptions();
  options.gaussian.iterations_per_keyframe = 5;
  options.gaussian.live_train_when_idle = false;  // the map stays as it is once its job is done
  MappingStage stage(options, MappingMode::kLive);
  const Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
  const CameraIntrinsics camera = kf.frame.camera;
  const Timestamp dt = 33'333'333;
  stage.observePose({0, Eigen::Isometry3d::Identity(), true, false});
  stage.observePose({dt, Eigen::Isometry3d::Identity(), true, false});
  stage.addKeyframe(std::make_shared<Keyframe>(kf));
  stage.gaussians().waitUntilIdle();
  const cv::Mat depth_alone = stage.predictedDepth(2 * dt, camera);
  const RenderedView view_alone = stage.renderView(Eigen::Isometry3d::Identity(), camera);
  ASSERT_FALSE(depth_alone.empty());
  ASSERT_FALSE(view_alone.bgr.empty());
  constexpr int kRenders = 20;
  int depth_differs = 0, view_differs = 0;
  std::thread viewer([&] {
    for (int i = 0; i < kRenders; ++i) {
      const RenderedView v = stage.renderView(Eigen::Isometry3d::Identity(), camera);
      if (cv::norm(v.bgr, view_alone.bgr, cv::NORM_INF) != 0 ||
          cv::norm(v.depth_m, view_alone.depth_m, cv::NORM_INF) != 0)
        ++view_differs;
    }
  });
  for (int i = 0; i < kRenders; ++i) {
    if (cv::norm(stage.predictedDepth(2 * dt, camera), depth_alone, cv::NORM_INF) != 0) ++depth_differs;
  }
  viewer.join();
  EXPECT_EQ(depth_differs, 0) << "of " << kRenders;
  EXPECT_EQ(view_differs, 0) << "of " << kRenders;
  EXPECT_EQ(stage.stats().predicted_depth_rendered, static_cast<std::size_t>(kRenders + 1));
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
