// ATE / RPE / Umeyama / interpolation / Bonn correction / trajectory plot.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "dypho/tools/evaluation.h"
#include "dypho/tools/trajectory_plot.h"

namespace fs = std::filesystem;
using namespace dypho;
using namespace dypho::tools;

namespace DYPHO_UNITY_ID {

Eigen::Isometry3d randomRigid(std::mt19937& rng, double max_t_m = 10.0) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(-max_t_m, max_t_m);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(Eigen::Vector4d(n(rng), n(rng), n(rng), n(rng)).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return T;
}

/// A smooth non-planar 3-D trajectory sampled at `rate_hz` for `duration_s`, with turning camera.
std::vector<StampedPose> curvyTrajectory(double rate_hz, double duration_s, double t0 = 1000.0) {
  std::vector<StampedPose> out;
  const int n = static_cast<int>(std::round(duration_s * rate_hz));
  for (int i = 0; i <= n; ++i) {
    const double t = i / rate_hz;
    StampedPose p;
    p.stamp_s = t0 + t;
    p.T_world_camera.translation() = Eigen::Vector3d(std::cos(0.5 * t) * 2.0, std::sin(0.7 * t), 0.3 * t);
    p.T_world_camera.linear() = (Eigen::AngleAxisd(0.3 * t, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(0.1 * std::sin(t), Eigen::Vector3d::UnitX()))
                                    .toRotationMatrix();
    out.push_back(p);
  }
  return out;
}

std::vector<StampedPose> transformed(const Eigen::Isometry3d& T_new_old, std::vector<StampedPose> poses) {
  for (auto& p : poses) p.T_world_camera = T_new_old * p.T_world_camera;
  return poses;
}

TEST(Umeyama, RecoversRandomRigidTransform) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Isometry3d T = randomRigid(rng);
    std::vector<Eigen::Vector3d> src, dst;
    for (int i = 0; i < 20; ++i) {
      src.emplace_back(u(rng), u(rng), u(rng));
      dst.push_back(T * src.back());
    }
    const Eigen::Isometry3d est = umeyamaAlignNoScale(src, dst);
    // Noise-free data: only floating-point error (values ~10, eps 2e-16) -> 1e-9 is generous.
    EXPECT_LT((est.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
    EXPECT_NEAR(est.linear().determinant(), 1.0, 1e-12);
  }
  EXPECT_THROW(umeyamaAlignNoScale({Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()},
                                   {Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()}),
               std::runtime_error);
  EXPECT_THROW(umeyamaAlignNoScale(std::vector<Eigen::Vector3d>(3), std::vector<Eigen::Vector3d>(4)),
               std::runtime_error);
}

TEST(Interpolation, LinearPositionSlerpRotation) {
  StampedPose a, b;
  a.stamp_s = 10.0;
  a.T_world_camera.translation() = Eigen::Vector3d(0, 0, 0);
  b.stamp_s = 10.08;
  b.T_world_camera.translation() = Eigen::Vector3d(0.8, -0.4, 0.2);
  b.T_world_camera.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const std::vector<StampedPose> gt = {a, b};

  const auto q = interpolatePose(gt, 10.02, 0.1);  // a quarter of the way
  ASSERT_TRUE(q.has_value());
  EXPECT_LT((q->translation() - Eigen::Vector3d(0.2, -0.1, 0.05)).norm(), 1e-9);
  const Eigen::AngleAxisd aa(q->linear());
  EXPECT_NEAR(aa.angle(), M_PI / 8, 1e-9);  // slerp: a quarter of 90 deg about z
  EXPECT_NEAR(aa.axis().z(), 1.0, 1e-9);

  ASSERT_TRUE(interpolatePose(gt, 10.08, 0.1).has_value());  // exact stamp -> that sample
  EXPECT_TRUE(interpolatePose(gt, 10.08, 0.1)->isApprox(b.T_world_camera, 1e-12));
  EXPECT_TRUE(interpolatePose(gt, 10.0, 0.01)->isApprox(a.T_world_camera, 1e-12));  // exact even with small gap
  EXPECT_FALSE(interpolatePose(gt, 9.99, 0.1).has_value());                         // before the ground truth
  EXPECT_FALSE(interpolatePose(gt, 10.09, 0.1).has_value());                        // after it
  EXPECT_FALSE(interpolatePose(gt, 10.04, 0.05).has_value());                       // samples 0.08 s apart > 0.05 s
}

TEST(Ate, ZeroForRigidlyTransformedCopy) {
  std::mt19937 rng(11);
  const auto gt = curvyTrajectory(30.0, 10.0);
  const Eigen::Isometry3d T = randomRigid(rng);
  const AteResult r = computeAte(transformed(T, gt), gt);
  EXPECT_EQ(r.num_pairs, gt.size());
  // Exact data: errors are floating-point noise on ~10 m coordinates.
  EXPECT_LT(r.rmse_m, 1e-9);
  EXPECT_LT(r.max_m, 1e-9);
  EXPECT_LT((r.T_gt_est.matrix() - T.inverse().matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(r.est_aligned_xyz.size(), r.num_pairs);
  EXPECT_EQ(r.gt_xyz.size(), r.num_pairs);
  EXPECT_EQ(r.stamps_s.size(), r.num_pairs);
}

// A copy shrunk by 0.9 about an arbitrary point and moved rigidly: the rigid ATE sees the
// scale error, the alignment with scale removes it exactly and returns 1 / 0.9.
TEST(Ate, WithScaleRemovesAScaleErrorAndReportsIt) {
  std::mt19937 rng(17);
  const auto gt = curvyTrajectory(30.0, 10.0);
  std::vector<StampedPose> shrunk = gt;
  const Eigen::Vector3d centre(1.0, -2.0, 0.5);
  for (StampedPose& p : shrunk)
    p.T_world_camera.translation() = centre + 0.9 * (p.T_world_camera.translation() - centre);
  const auto est = transformed(randomRigid(rng), shrunk);
  const AteResult rigid = computeAte(est, gt);
  const AteResult scaled = computeAte(est, gt, 0.1, AteAlignment::kWithScale);
  EXPECT_EQ(rigid.scale, 1.0);
  EXPECT_GT(rigid.rmse_m, 0.05) << "a 10 % scale error over a ~10 m path";
  // Exact data: floating-point error only.
  EXPECT_LT(scaled.rmse_m, 1e-9);
  EXPECT_NEAR(scaled.scale, 1.0 / 0.9, 1e-9);
  std::vector<StampedPose> still = gt;
  for (StampedPose& p : still) p.T_world_camera.translation().setZero();
  EXPECT_THROW(computeAte(still, gt, 0.1, AteAlignment::kWithScale), std::runtime_error);
}

TEST(Ate, KnownErrorsThatCannotBeAlignedAway) {
  // Ground truth holds still for two samples at a time. The estimate is shifted by +a_k along a fixed
  // unit direction at the first sample of pair k and by -a_k at the second. The offsets sum to zero
  // and are uncorrelated with the positions, so the best rigid alignment is the identity and every
  // error is exactly a_k. The estimate is then moved by an arbitrary rigid transform.
  std::mt19937 rng(5);
  const auto path = curvyTrajectory(15.0, 8.0);
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 2, -2).normalized();
  std::vector<StampedPose> gt, est;
  std::vector<double> errors;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const double a_k = 0.01 * (1 + k % 3);  // 1, 2, 3 cm
    for (int s = 0; s < 2; ++s) {
      StampedPose g = path[k];
      g.stamp_s = 1000.0 + 0.05 * (2 * k + s);
      gt.push_back(g);
      StampedPose e = g;
      e.T_world_camera.translation() += (s == 0 ? a_k : -a_k) * dir;
      est.push_back(e);
      errors.push_back(a_k);
    }
  }
  const AteResult r = computeAte(transformed(randomRigid(rng), est), gt);
  double sum = 0, sum_sq = 0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  const double n = static_cast<double>(errors.size());
  std::sort(errors.begin(), errors.end());
  ASSERT_EQ(r.num_pairs, errors.size());
  // The closed form holds exactly; 1e-9 m covers floating-point error.
  EXPECT_NEAR(r.rmse_m, std::sqrt(sum_sq / n), 1e-9);
  EXPECT_NEAR(r.mean_m, sum / n, 1e-9);
  EXPECT_NEAR(r.max_m, 0.03, 1e-9);
  EXPECT_NEAR(r.median_m, 0.5 * (errors[errors.size() / 2 - 1] + errors[errors.size() / 2]), 1e-9);
  EXPECT_NEAR(r.std_m, std::sqrt(sum_sq / n - (sum / n) * (sum / n)), 1e-9);
  std::printf("known-answer ATE: rmse %.6f m (expected %.6f)\n", r.rmse_m, std::sqrt(sum_sq / n));
}

TEST(Ate, InterpolatesGroundTruthBetweenSamples) {
  // Ground truth moving at constant velocity with constant angular rate: linear interpolation and
  // slerp are exact, so an estimate sampled in between (at 30 Hz vs 100 Hz) has zero ATE.
  std::vector<StampedPose> gt, est;
  for (int i = 0; i <= 500; ++i) {
    StampedPose p;
    p.stamp_s = 50.0 + 0.01 * i;
    p.T_world_camera.translation() = Eigen::Vector3d(0.3, -0.2, 0.1) * (p.stamp_s - 50.0) + Eigen::Vector3d(1, 2, 3);
    p.T_world_camera.linear() =
        Eigen::AngleAxisd(0.5 * (p.stamp_s - 50.0), Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
    gt.push_back(p);
  }
  for (int i = 0; i < 140; ++i) {
    const double t = 50.0037 + i / 30.0;
    StampedPose p;
    p.stamp_s = t;
    p.T_world_camera.translation() = Eigen::Vector3d(0.3, -0.2, 0.1) * (t - 50.0) + Eigen::Vector3d(1, 2, 3);
    est.push_back(p);
  }
  est.push_back(est.back());
  est.back().stamp_s = 60.0;  // beyond the ground truth: not paired
  const AteResult r = computeAte(est, gt);
  EXPECT_EQ(r.num_pairs, 140u);
  EXPECT_LT(r.rmse_m, 1e-9);
  // Too few pairs -> clear error.
  EXPECT_THROW(computeAte({est[0], est[1]}, gt), std::runtime_error);
  EXPECT_THROW(computeAte(est, transformed(Eigen::Isometry3d::Identity(), {})), std::runtime_error);
}

TEST(Rpe, ZeroForRigidlyTransformedCopy) {
  std::mt19937 rng(2);
  const auto gt = curvyTrajectory(30.0, 6.0);
  const RpeResult r = computeRpe(transformed(randomRigid(rng), gt), gt, 1.0);
  // Every pose with a partner exactly 1 s later (gt.size() - 30), plus up to 3 near the end whose
  // closest partner is the last pose, within max_gap_s = 0.1 s of the target time.
  EXPECT_GE(r.num_pairs, gt.size() - 30);
  EXPECT_LE(r.num_pairs, gt.size() - 27);
  EXPECT_LT(r.trans_rmse_m, 1e-9);
  EXPECT_LT(r.rot_rmse_deg, 1e-6);  // angle from a near-identity rotation: ~sqrt(eps) rad
}

TEST(Rpe, ConstantDrift) {
  // Translation drift: ground truth moves 1 m/s along x, the estimate 1.05 m/s; over 1 s the
  // relative motions differ by 0.05 m. Rotation drift: ground truth yaws 10 deg/s, the estimate
  // 12 deg/s, in place; over 1 s the relative rotations differ by 2 deg.
  const double rate_hz = 30.0, v_gt = 1.0, v_est = 1.05, w_gt = 10.0, w_est = 12.0;
  std::vector<StampedPose> gt, est, gt_rot, est_rot;
  for (int i = 0; i <= 300; ++i) {
    const double t = i / rate_hz;
    StampedPose g, e;
    g.stamp_s = e.stamp_s = t;
    g.T_world_camera.translation() = Eigen::Vector3d(v_gt * t, 0, 0);
    e.T_world_camera.translation() = Eigen::Vector3d(v_est * t, 0, 0);
    gt.push_back(g);
    est.push_back(e);
    g.T_world_camera = Eigen::Isometry3d(Eigen::AngleAxisd(w_gt * t * M_PI / 180, Eigen::Vector3d::UnitZ()));
    e.T_world_camera = Eigen::Isometry3d(Eigen::AngleAxisd(w_est * t * M_PI / 180, Eigen::Vector3d::UnitZ()));
    gt_rot.push_back(g);
    est_rot.push_back(e);
  }
  // max_gap_s = 0.01 s (< 1/30 s) so that only pairs exactly 1 s apart count (i = 0..270); the
  // estimate stamps equal the ground-truth stamps, so no interpolation is involved.
  const double max_gap_s = 0.01;
  const RpeResult rt = computeRpe(est, gt, 1.0, max_gap_s);
  EXPECT_EQ(rt.num_pairs, 271u);
  EXPECT_NEAR(rt.trans_rmse_m, (v_est - v_gt) * 1.0, 1e-9);
  EXPECT_NEAR(rt.rot_rmse_deg, 0.0, 1e-6);
  const RpeResult rr = computeRpe(est_rot, gt_rot, 1.0, max_gap_s);
  EXPECT_NEAR(rr.rot_rmse_deg, (w_est - w_gt) * 1.0, 1e-7);
  EXPECT_NEAR(rr.trans_rmse_m, 0.0, 1e-9);
  const RpeResult rh = computeRpe(est_rot, gt_rot, 0.5, max_gap_s);  // half the delta, half the drift
  EXPECT_NEAR(rh.rot_rmse_deg, (w_est - w_gt) * 0.5, 1e-7);
  EXPECT_NEAR(rh.delta_s, 0.5, 0.0);
  EXPECT_THROW(computeRpe(est, gt, 100.0), std::runtime_error);  // longer than the trajectory
  EXPECT_THROW(computeRpe(est, gt, 0.0), std::runtime_error);
}

TEST(Bonn, CorrectionOfIdentity) {
  Eigen::Isometry3d T_ros = Eigen::Isometry3d::Identity();
  T_ros.matrix() = bonnTRos();
  const Eigen::Isometry3d T_m = bonnTmRigid();
  // T_m's rotation block is orthonormal and close to the published block divided by its scale.
  EXPECT_LT((T_m.linear() * T_m.linear().transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(T_m.linear().determinant(), 1.0, 1e-12);
  const Eigen::Matrix3d published = bonnTmPublished().topLeftCorner<3, 3>();
  const double scale = std::cbrt(published.determinant());
  std::printf("Bonn T_m: scale of published 3x3 block %.5f, distance to rotation %.2e\n", scale,
              (published / scale - T_m.linear()).norm());
  // Singular values 1.05924..1.05935 (spread 1e-4): the rigid part agrees to ~1e-4 after scaling.
  EXPECT_LT((published / scale - T_m.linear()).norm(), 1e-3);

  StampedPose id;
  id.stamp_s = 7.0;
  const auto out = applyBonnCorrection({id});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].stamp_s, 7.0);
  EXPECT_LT((out[0].T_world_camera.matrix() - (T_ros * T_ros * T_m).matrix()).cwiseAbs().maxCoeff(), 1e-12);
  // T_ros * T_ros = I, so the identity ground truth maps to T_m itself.
  EXPECT_LT((out[0].T_world_camera.matrix() - T_m.matrix()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Bonn, PositionsMatchPublishedFormula) {
  std::mt19937 rng(9);
  std::vector<StampedPose> gt;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.stamp_s = i;
    p.T_world_camera = randomRigid(rng, 3.0);
    gt.push_back(p);
  }
  const auto out = applyBonnCorrection(gt);
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const Eigen::Matrix4d raw = bonnTRos() * gt[i].T_world_camera.matrix() * bonnTRos() * bonnTmPublished();
    EXPECT_LT((out[i].T_world_camera.translation() - raw.topRightCorner<3, 1>()).norm(), 1e-12);
  }
}

TEST(TrajectoryPlot, WritesPng) {
  std::mt19937 rng(4);
  const auto gt = curvyTrajectory(30.0, 10.0);
  auto est = transformed(randomRigid(rng), gt);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (auto& p : est) p.T_world_camera.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  const AteResult ate = computeAte(est, gt);
  std::string tmpl = (fs::temp_directory_path() / "dypho_plot_XXXXXX").string();
  ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
  const fs::path file = fs::path(tmpl) / "plot.png";
  writeTrajectoryPlotPng(file.string(), ate, "test plot");
  const cv::Mat img = cv::imread(file.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.size(), cv::Size(1000, 800));
  // Both curves are drawn: black-ish (ground truth) and red-dominant (estimate) pixels exist.
  int dark = 0, red = 0;
  for (int v = 0; v < img.rows; ++v) {
    for (int u = 0; u < img.cols; ++u) {
      const cv::Vec3b c = img.at<cv::Vec3b>(v, u);
      if (c[0] < 60 && c[1] < 60 && c[2] < 60) ++dark;
      if (c[2] > 180 && c[0] < 90 && c[1] < 90) ++red;
    }
  }
  EXPECT_GT(dark, 1000);
  EXPECT_GT(red, 500);
  int entries = 0;
  for (const auto& e : fs::directory_iterator(tmpl)) {
    ++entries;
    EXPECT_EQ(e.path().filename(), "plot.png");
  }
  EXPECT_EQ(entries, 1);
  EXPECT_THROW(renderTrajectoryPlot(AteResult{}, "empty"), std::runtime_error);
  fs::remove_all(tmpl);
}  // namespace DYPHO_UNITY_ID
}  // namespace DYPHO_UNITY_ID
