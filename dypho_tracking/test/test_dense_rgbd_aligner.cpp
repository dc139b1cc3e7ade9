/// DenseRgbdAligner: recovers a known motion of the camera in front of a textured wall from the
/// pixels, keeps the prior where the pixels cannot tell, ignores an unmasked mover; and the
/// feature prior's information against a numerical Jacobian.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "dypho/tracking/dense_rgbd_aligner.h"
#include "synthetic_scene.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

constexpr double kWallDepthM = 2.0;
constexpr double kFocalPx = 525.0;  // test::testCamera()
constexpr double kCx = 319.5, kCy = 239.5;

/// The wall seen after the camera moved by (tx, 0, tz) [m] without turning: a zoom about the
/// principal point and a sideways shift (exact for a fronto-parallel plane), and its depth.
RgbdFrame wallAfterMotion(const cv::Mat& wall, double tx_m, double tz_m, Timestamp stamp_ns) {
  const double zoom = kWallDepthM / (kWallDepthM - tz_m);
  const double shift_px = -kFocalPx * tx_m / (kWallDepthM - tz_m);
  const cv::Matx23d A(zoom, 0, kCx - zoom * kCx + shift_px, 0, zoom, kCy - zoom * kCy);
  cv::Mat moved;
  cv::warpAffine(wall, moved, A, wall.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return test::planarFrame(moved, kWallDepthM - tz_m, stamp_ns);
}

/// T_current_reference after the camera moved by (tx, 0, tz) [m].
Eigen::Isometry3d currentFromReference(double tx_m, double tz_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(-tx_m, 0.0, -tz_m);
  return T;
}

double angleDeg(const Eigen::Isometry3d& T) { return Eigen::AngleAxisd(T.rotation()).angle() * 180.0 / M_PI; }

TEST(DenseRgbdAligner, RecoversSidewaysAndForwardMotionFromPixelsAlone) {
  const cv::Mat wall = test::texturedImage(5);
  DenseRgbdAligner aligner{DenseAlignerSettings()};
  ASSERT_TRUE(aligner.setReference(3, test::planarFrame(wall, kWallDepthM, 0), cv::Mat()));
  EXPECT_EQ(aligner.referenceId(), 3);
  aligner.setCurrent(wallAfterMotion(wall, 0.03, 0.05, 1), cv::Mat());
  const DenseAlignment a = aligner.align(Eigen::Isometry3d::Identity(), DensePosePrior());
  ASSERT_TRUE(a.success) << a.message;
  // 3 cm sideways = 7.9 px, 5 cm forward = a 2.5 % zoom, found from the identity without a prior.
  // Bound 2 mm: a quarter of a working pixel (7.6 mm at 2 m, scale 0.5); the depth residuals
  // pin z, the texture x.
  const Eigen::Isometry3d error = a.T_current_reference * currentFromReference(0.03, 0.05).inverse();
  EXPECT_LT(error.translation().norm(), 0.002);
  EXPECT_LT(angleDeg(error), 0.05);
  EXPECT_GT(a.photometric_samples, 500);
  EXPECT_GT(a.depth_samples, 500);
}

TEST(DenseRgbdAligner, KeepsThePriorWherePixelsCannotTell) {
  // A blank wall: no texture, so only the depth residuals speak; they fix z (and the tilt), not
  // the sideways position, which must stay where the prior (the feature pose) put it.
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
  DenseRgbdAligner aligner{DenseAlignerSettings()};
  ASSERT_TRUE(aligner.setReference(0, test::planarFrame(blank, kWallDepthM, 0), cv::Mat()));
  aligner.setCurrent(wallAfterMotion(blank, 0.0, 0.04, 1), cv::Mat());
  DensePosePrior prior;
  prior.T_current_reference = currentFromReference(0.01, 0.0);  // sideways right, depth wrong by 4 cm
  prior.information = PoseInformation::Identity() * 1e4;        // 1 cm / 0.6 deg standard deviation
  const DenseAlignment a = aligner.align(prior.T_current_reference, prior);
  ASSERT_TRUE(a.success) << a.message;
  EXPECT_EQ(a.photometric_samples, 0);
  // z from the depth residuals: 1000+ samples of sigma 8 mm outweigh the prior's 1 cm by far.
  EXPECT_NEAR(a.T_current_reference.translation().z(), -0.04, 0.002);
  EXPECT_NEAR(a.T_current_reference.translation().x(), -0.01, 0.001);
}

TEST(DenseRgbdAligner, FollowsTheWallNotAnUnmaskedMover) {
  // A textured slab 0.8 m in front of the wall covers a third of the image and moves 12 px to
  // the right while the camera moves 2 cm to the right (the wall shifts 5.25 px left); no mask.
  const cv::Mat wall = test::texturedImage(6);
  const cv::Mat slab = test::texturedImage(7);
  const cv::Rect area(200, 100, 240, 240);
  RgbdFrame reference = test::planarFrame(wall, kWallDepthM, 0);
  RgbdFrame current = wallAfterMotion(wall, 0.02, 0.0, 1);
  cv::Mat slab_bgr;
  cv::cvtColor(slab, slab_bgr, cv::COLOR_GRAY2BGR);
  slab_bgr(area).copyTo(reference.bgr(area));
  reference.depth_m(area).setTo(1.2);
  const cv::Rect moved = area + cv::Point(12, 0);
  slab_bgr(area).copyTo(current.bgr(moved));
  current.depth_m(moved).setTo(1.2);
  DenseRgbdAligner aligner{DenseAlignerSettings()};
  ASSERT_TRUE(aligner.setReference(0, reference, cv::Mat()));
  aligner.setCurrent(current, cv::Mat());
  const DenseAlignment a = aligner.align(Eigen::Isometry3d::Identity(), DensePosePrior());
  ASSERT_TRUE(a.success) << a.message;
  // Following the slab would be 12 px at 1.2 m = 2.7 cm the other way. Bound 3 mm (robust
  // weights leave a small pull of the slab's border pixels).
  const Eigen::Isometry3d error = a.T_current_reference * currentFromReference(0.02, 0.0).inverse();
  EXPECT_LT(error.translation().norm(), 0.003);
}

TEST(DenseRgbdAligner, FeatureInformationIsTheGaussNewtonHessianOfTheReprojections) {
  const Pinhole pinhole{kFocalPx, kFocalPx, kCx, kCy};
  Eigen::Isometry3d T_camera_world = Eigen::Isometry3d::Identity();
  T_camera_world.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, -1.0, 0.2).normalized()).toRotationMatrix();
  T_camera_world.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  std::vector<PoseObservation> observations;
  cv::RNG rng(3);
  for (int i = 0; i < 40; ++i) {
    PoseObservation o;
    const Eigen::Vector3d p_c(rng.uniform(-1.0, 1.0), rng.uniform(-0.8, 0.8), rng.uniform(1.0, 4.0));
    o.p_world_m = T_camera_world.inverse() * p_c;
    o.uv_px = pinhole.project(p_c);
    o.level = i % 3;
    o.depth_m = p_c.z();
    observations.push_back(o);
  }
  const double scale_factor = 1.2, baseline_m = 0.08;
  TrackingOptions options;
  options.scale_factor = scale_factor;
  options.depth_baseline_m = baseline_m;
  const PoseInformation H = featurePoseInformation(PoseOptimizer(options), observations, pinhole, T_camera_world);
  // The same from a numerical Jacobian of [u, v, u - b fx / z] / sigma under T' = exp(d) T.
  PoseInformation numeric = PoseInformation::Zero();
  const double h = 1e-6;
  for (const PoseObservation& o : observations) {
    const double sigma = std::pow(scale_factor, o.level);
    auto residual = [&](const Eigen::Isometry3d& T) -> Eigen::Vector3d {
      const Eigen::Vector3d q = T * o.p_world_m;
      const Eigen::Vector2d uv = pinhole.project(q);
      return Eigen::Vector3d(uv.x(), uv.y(), uv.x() - baseline_m * pinhole.fx / q.z()) / sigma;
    };
    Eigen::Matrix<double, 3, 6> J;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> d = Eigen::Matrix<double, 6, 1>::Zero();
      d[k] = h;
      Eigen::Isometry3d plus = Eigen::Isometry3d::Identity(), minus = Eigen::Isometry3d::Identity();
      plus.linear() = Eigen::AngleAxisd(d.tail<3>().norm(),
                                        (d.tail<3>().norm() > 0 ? d.tail<3>().normalized() : Eigen::Vector3d::UnitX()))
                          .toRotationMatrix();
      plus.translation() = d.head<3>();
      minus = plus.inverse();
      J.col(k) = (residual(plus * T_camera_world) - residual(minus * T_camera_world)) / (2.0 * h);
    }
    numeric += J.transpose() * J;
  }
  // Central differences at h = 1e-6 agree to ~1e-6 relative; bound 1e-4 of the largest entry.
  EXPECT_LT((H - numeric).cwiseAbs().maxCoeff(), 1e-4 * numeric.cwiseAbs().maxCoeff());
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
