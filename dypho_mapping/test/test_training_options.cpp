/// Training options of the Gaussian map beyond the paper's loss:
///  - pose_refinement: a keyframe handed over at a wrong pose moves towards the pose the rest of
///    the map agrees on, the first keyframe holds the gauge, the bound holds, and a tracking
///    correction keeps the refinement's offset;
///  - exposure_mean_gauge: the map's colours move into the keyframes' mean exposure while the
///    keyframes' renders stay as they were.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "dypho/mapping/gaussian_mapper.h"
#include "plane_keyframe.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

/// A textured fronto-parallel plane at 2 m; 1 cm sideways is 1 px at this focal length.
Keyframe planeKeyframe(std::int64_t id, double x_m, double y_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x_m, y_m, 0.0);
  return test::texturedPlaneKeyframe(id, T, 160, 120, 200.0, 8);
}

GaussianMapperOptions refineOptions(bool refine) {
  GaussianMapperOptions o;
  o.train_downsample = 1;
  o.coverage_stride_px = 4;
  o.feature_samples = 0;
  o.training_idle_class = false;
  o.exposure_compensation = false;
  o.window_size = 4;
  o.pose_refinement = refine;
  return o;
}

Eigen::Isometry3d poseOf(const GaussianMapper& mapper, std::int64_t id) {
  for (const auto& [kf_id, T] : mapper.keyframePoses())
    if (kf_id == id) return T;
  ADD_FAILURE() << "keyframe " << id << " not in the map";
  return Eigen::Isometry3d::Identity();
}

/// Keyframes 1 and 3 at their true poses; keyframe 2 seen from x = 0.04 m but handed over at
/// x = 0.04 + error_m, after `iterations_before` on the first two. Returns keyframe 2's
/// translation error after `iterations` more.
struct Refined {
  double error_m = 0.0;
  Eigen::Isometry3d T_first;
  Eigen::Isometry3d T_second;
};

Refined trainWithAWrongPose(const GaussianMapperOptions& o, double error_m, int iterations_before, int iterations) {
  GaussianMapper mapper(o);
  EXPECT_TRUE(mapper.addKeyframe(planeKeyframe(1, 0.0, 0.0)).added);
  EXPECT_TRUE(mapper.addKeyframe(planeKeyframe(3, 0.08, 0.0)).added);
  mapper.optimize(iterations_before);
  Keyframe wrong = planeKeyframe(2, 0.04, 0.0);
  wrong.T_world_camera.translation().x() += error_m;
  EXPECT_TRUE(mapper.addKeyframe(wrong).added);
  mapper.optimize(iterations);
  Refined r;
  r.T_second = poseOf(mapper, 2);
  r.error_m = (r.T_second.translation() - Eigen::Vector3d(0.04, 0.0, 0.0)).norm();
  r.T_first = poseOf(mapper, 1);
  return r;
}

TEST(PoseRefinement, AWrongKeyframePoseMovesTowardsTheMap) {
  constexpr double kErrorM = 0.02;  // 2 px on the plane
  const Refined off = trainWithAWrongPose(refineOptions(false), kErrorM, 0, 20);
  const Refined on = trainWithAWrongPose(refineOptions(true), kErrorM, 100, 400);
  std::printf("keyframe pose error: %.2f mm without refinement, %.2f mm with\n", 1e3 * off.error_m, 1e3 * on.error_m);
  EXPECT_NEAR(off.error_m, kErrorM, 1e-9);  // off: the pose stays where tracking put it
  // The other keyframes' Gaussians hold the texture where it is: the pose must lose at least
  // half of its error (checker cells of 8 px = 8 cm: no false match near 2 cm).
  EXPECT_LT(on.error_m, 0.5 * kErrorM);
  // Keyframe 1 holds the gauge.
  EXPECT_TRUE(on.T_first.isApprox(Eigen::Isometry3d::Identity(), 1e-12));
}

TEST(PoseRefinement, StepsBeyondTheBoundAreNotApplied) {
  GaussianMapperOptions o = refineOptions(true);
  o.pose_refinement_max_translation_m = 0.002;
  const Refined r = trainWithAWrongPose(o, 0.02, 50, 100);
  // The refined pose stays within 2 mm of where tracking put it (0.06 m).
  EXPECT_LE(std::abs(r.T_second.translation().x() - 0.06), 0.002 + 1e-9);
  EXPECT_LE(r.T_second.translation().tail<2>().norm(), 0.002 + 1e-9);
}

TEST(PoseRefinement, ATrackingCorrectionKeepsTheRefinementsOffset) {
  GaussianMapper mapper(refineOptions(true));
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(1, 0.0, 0.0)).added);
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(3, 0.08, 0.0)).added);
  Keyframe wrong = planeKeyframe(2, 0.04, 0.0);
  wrong.T_world_camera.translation().x() += 0.02;
  const Eigen::Isometry3d T_tracked = wrong.T_world_camera;
  ASSERT_TRUE(mapper.addKeyframe(wrong).added);
  mapper.optimize(300);
  const Eigen::Isometry3d T_refined = poseOf(mapper, 2);
  const Eigen::Isometry3d offset = T_tracked.inverse() * T_refined;
  ASSERT_GT(offset.translation().norm(), 1e-3) << "the test needs a refined pose";
  // Tracking moves keyframe 2 by 10 cm up (say, a loop closure): the refined pose moves with it.
  Eigen::Isometry3d T_corrected = T_tracked;
  T_corrected.translation().y() += 0.1;
  ASSERT_TRUE(mapper.updateKeyframePose(2, T_corrected));
  const Eigen::Isometry3d T_after = poseOf(mapper, 2);
  EXPECT_TRUE(T_after.isApprox(T_corrected * offset, 1e-12));
}

/// Mean grey level of an image's pixels.
double meanLevel(const cv::Mat& bgr) {
  const cv::Scalar m = cv::mean(bgr);
  return (m[0] + m[1] + m[2]) / 3.0;
}

TEST(ExposureGauge, TheMapMovesIntoTheMeanExposureAndKeyframeRendersStay) {
  // Two views of one plane; the second image is 40 % darker (auto exposure).
  auto run = [](bool mean_gauge, KeyframeEvaluation* before, KeyframeEvaluation* after) {
    GaussianMapperOptions o = refineOptions(false);
    o.exposure_compensation = true;
    o.exposure_mean_gauge = mean_gauge;
    o.final_refine_iterations = 0;  // finish() only moves the gauge
    GaussianMapper mapper(o);
    Keyframe a = planeKeyframe(1, 0.0, 0.0);
    Keyframe b = planeKeyframe(2, 0.03, 0.0);
    b.frame.bgr.convertTo(b.frame.bgr, CV_8UC3, 0.6);
    EXPECT_TRUE(mapper.addKeyframe(a).added);
    EXPECT_TRUE(mapper.addKeyframe(b).added);
    mapper.optimize(200);
    *before = mapper.evaluateKeyframes();
    mapper.finish();
    *after = mapper.evaluateKeyframes();
    return meanLevel(mapper.render(a.T_world_camera, a.frame.camera).bgr) / meanLevel(a.frame.bgr);
  };
  KeyframeEvaluation first_before, first_after, mean_before, mean_after;
  const double first_level = run(false, &first_before, &first_after);
  const double mean_level = run(true, &mean_before, &mean_after);
  std::printf("plain render / keyframe 1 image: %.3f in the first keyframe's gauge, %.3f in the mean gauge\n",
              first_level, mean_level);
  // The first keyframe's gauge renders keyframe 1's brightness (5 % for the fit); the mean gauge
  // sits between the images (1.0 and 0.6): log-mean gain sqrt(0.6) = 0.77, +-0.05.
  EXPECT_NEAR(first_level, 1.0, 0.05);
  EXPECT_NEAR(mean_level, std::sqrt(0.6), 0.05);
  // The keyframes' exposed renders do not change (float rounding and the colour clamp: 0.05 dB).
  EXPECT_NEAR(mean_after.psnr_db, mean_before.psnr_db, 0.05);
  EXPECT_EQ(first_after.psnr_db, first_before.psnr_db);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
