/// StaticSceneCheck: agreement scores and the dense refinement on a textured wall, with and
/// without a moving textured slab in front of it.
#include <gtest/gtest.h>

#include "dypho/tracking/static_scene_check.h"
#include "synthetic_scene.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

constexpr double kWallDepthM = 2.0;
constexpr double kFocalPx = 525.0;  // test::testCamera()

/// Camera translation along x that shifts the wall by `px` pixels (to the left for px > 0).
double sidewaysForShiftM(int px) { return px * kWallDepthM / kFocalPx; }

/// The pose of the reference camera in the current one after the camera moved by +x_m.
Eigen::Isometry3d currentFromReference(double x_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = -x_m;
  return T;
}

/// Current frame of the wall after the camera moved sideways by `shift_px` (in wall pixels).
RgbdFrame wallAfterShift(const cv::Mat& wall, int shift_px) {
  return test::planarFrame(test::shifted(wall, -shift_px, 0), kWallDepthM, 1);
}

TEST(StaticSceneCheck, ScoresTheTruePoseAboveAWrongOne) {
  const cv::Mat wall = test::texturedImage(3);
  StaticSceneCheck check{StaticSceneCheckSettings()};
  ASSERT_TRUE(check.setReference(7, test::planarFrame(wall, kWallDepthM, 0), cv::Mat()));
  EXPECT_EQ(check.referenceId(), 7);
  check.setCurrent(wallAfterShift(wall, 6), cv::Mat());
  const StaticAgreement at_truth = check.score(currentFromReference(sidewaysForShiftM(6)));
  const StaticAgreement at_start = check.score(Eigen::Isometry3d::Identity());
  // The integer shift is exact and the wall flat: only the replicated border and the Sobel
  // border differ, so nearly every sample agrees at the true pose.
  EXPECT_GT(at_truth.ratio(), 0.95);
  // 6 px off (3 px at the working scale 0.5) on this texture: most samples disagree.
  EXPECT_LT(at_start.ratio(), 0.6);
  EXPECT_GT(at_truth.checked, 500);
}

TEST(StaticSceneCheck, RefinementFindsTheTruePose) {
  const cv::Mat wall = test::texturedImage(4);
  StaticSceneCheck check{StaticSceneCheckSettings()};
  ASSERT_TRUE(check.setReference(0, test::planarFrame(wall, kWallDepthM, 0), cv::Mat()));
  check.setCurrent(wallAfterShift(wall, 6), cv::Mat());
  const Eigen::Isometry3d refined = check.refine(Eigen::Isometry3d::Identity());
  // 6 px = 2.3 cm at 2 m; one working pixel is 7.6 mm. Bound: 3 mm, well under a working pixel
  // (the sideways motion is observable; depth along z is only weakly so on a flat wall).
  EXPECT_NEAR(refined.translation().x(), -sidewaysForShiftM(6), 0.003);
  EXPECT_LT(Eigen::AngleAxisd(refined.rotation()).angle(), 0.003);
}

TEST(StaticSceneCheck, RefinementFollowsTheWallNotAMovingSlab) {
  // A textured slab at the wall's depth covers a third of the image and moves 4 px to the right
  // while the wall (the static scene) shifts 4 px to the left: no mask marks the slab. At one
  // depth no rigid motion explains both (two depths would: sideways motion plus yaw).
  const cv::Mat wall = test::texturedImage(5);
  const cv::Mat slab = test::texturedImage(6);
  const cv::Rect slab_ref(200, 0, 220, 480), slab_cur(204, 0, 220, 480);
  RgbdFrame reference = test::planarFrame(wall, kWallDepthM, 0);
  RgbdFrame current = wallAfterShift(wall, 4);
  cv::Mat slab_bgr;
  cv::cvtColor(slab, slab_bgr, cv::COLOR_GRAY2BGR);
  slab_bgr(slab_ref).copyTo(reference.bgr(slab_ref));
  reference.depth_m(slab_ref).setTo(static_cast<float>(kWallDepthM));
  slab_bgr(slab_ref).copyTo(current.bgr(slab_cur));
  current.depth_m(slab_cur).setTo(static_cast<float>(kWallDepthM));

  StaticSceneCheck check{StaticSceneCheckSettings()};
  ASSERT_TRUE(check.setReference(0, reference, cv::Mat()));
  check.setCurrent(current, cv::Mat());
  const Eigen::Isometry3d truth = currentFromReference(sidewaysForShiftM(4));
  const Eigen::Isometry3d refined = check.refine(Eigen::Isometry3d::Identity());
  // A flat wall leaves sideways translation and yaw nearly interchangeable, so the test compares
  // image motion: where the refined pose puts the wall's centre point (the slab went to +4 px).
  const Pinhole pinhole = Pinhole::fromIntrinsics(test::testCamera());
  auto u = [&](const Eigen::Isometry3d& T) { return pinhole.project(T * Eigen::Vector3d(0, 0, kWallDepthM)).x(); };
  EXPECT_NEAR(u(refined), u(truth), 0.5);  // the wall's motion (-4 px) within half a pixel
  // The slab's samples disagree at the true pose; the refined pose explains the wall as well as
  // the truth does and far more than the start.
  EXPECT_GT(check.score(refined).ratio(), check.score(truth).ratio() - 0.02);
  EXPECT_GT(check.score(refined).ratio(), check.score(Eigen::Isometry3d::Identity()).ratio() + 0.2);
}

TEST(StaticSceneCheck, MaskedPixelsAreNeitherSampledNorCompared) {
  const cv::Mat wall = test::texturedImage(7);
  cv::Mat left_half = cv::Mat::zeros(480, 640, CV_8UC1);
  left_half(cv::Rect(0, 0, 320, 480)).setTo(255);
  StaticSceneCheckSettings every_sample;
  every_sample.max_samples = 1000000;  // counts must not be capped
  StaticSceneCheck full{every_sample}, masked{every_sample};
  ASSERT_TRUE(full.setReference(0, test::planarFrame(wall, kWallDepthM, 0), cv::Mat()));
  ASSERT_TRUE(masked.setReference(0, test::planarFrame(wall, kWallDepthM, 0), left_half));
  const RgbdFrame same = test::planarFrame(wall, kWallDepthM, 1);
  full.setCurrent(same, cv::Mat());
  masked.setCurrent(same, cv::Mat());
  const int all = full.score(Eigen::Isometry3d::Identity()).checked;
  const int right = masked.score(Eigen::Isometry3d::Identity()).checked;
  EXPECT_LT(right, 0.6 * all);
  EXPECT_GT(right, 0.3 * all);
  // A current mask over the right half leaves nothing of the masked reference to compare.
  cv::Mat right_half = cv::Mat::zeros(480, 640, CV_8UC1);
  right_half(cv::Rect(320, 0, 320, 480)).setTo(255);
  masked.setCurrent(same, right_half);
  EXPECT_LT(masked.score(Eigen::Isometry3d::Identity()).checked, right / 20);
}

TEST(StaticSceneCheck, NoReferenceWithoutUsablePixels) {
  StaticSceneCheck check{StaticSceneCheckSettings()};
  const cv::Mat flat(480, 640, CV_8UC1, cv::Scalar(90));
  EXPECT_FALSE(check.setReference(0, test::planarFrame(flat, kWallDepthM, 0), cv::Mat()));
  EXPECT_EQ(check.referenceId(), -1);
  RgbdFrame no_depth = test::planarFrame(test::texturedImage(1), kWallDepthM, 0);
  no_depth.depth_m.setTo(0.f);
  EXPECT_FALSE(check.setReference(1, no_depth, cv::Mat()));
  check.setCurrent(no_depth, cv::Mat());
  EXPECT_EQ(check.score(Eigen::Isometry3d::Identity()).checked, 0);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
