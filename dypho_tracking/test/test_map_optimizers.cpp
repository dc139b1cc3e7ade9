/// Residual Jacobians (BA, pose graph), local BA and pose-graph loop correction on synthetic data.

#include <cmath>
#include <iostream>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "dypho/tracking/local_bundle_adjuster.h"
#include "dypho/tracking/loop_closer.h"
#include "dypho/tracking/motion_blur.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/pose_graph_optimizer.h"
#include "dypho/tracking/reprojection_error.h"
#include "jacobian_check.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

Pinhole testPinhole() { return Pinhole{525.0, 525.0, 319.5, 239.5}; }

Eigen::Isometry3d makePose(double rx, double ry, double rz, double tx, double ty, double tz) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(tx, ty, tz);
  return T;
}

std::vector<double> quat(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.rotation());
  return {q.x(), q.y(), q.z(), q.w()};
}

std::vector<double> vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

TEST(BaRgbdError, JacobiansMatchCentralDifferences) {
  const Eigen::Isometry3d T_cw = makePose(0.1, -0.2, 0.3, 0.05, -0.1, 0.2);
  const Eigen::Vector3d P(0.3, -0.2, 2.5);
  // Without a loss, and with a Huber width that the pixel part (tens of px off) and the depth
  // part (2.4 m measured, about 2.2 m predicted) both exceed.
  for (const double huber : {0.0, 2.0}) {
    BaRgbdError cost(Eigen::Vector2d(300, 250), Eigen::Matrix2d::Identity() / 1.44, testPinhole(), 2.4, 0.08 * 525.0,
                     1.44, huber);
    test::expectJacobiansMatch(cost, {quat(T_cw), vec(T_cw.translation()), vec(P)});
  }
}

TEST(BaRgbdError, JacobiansMatchCentralDifferencesWithABlurStreak) {
  const Eigen::Isometry3d T_cw = makePose(0.1, -0.2, 0.3, 0.05, -0.1, 0.2);
  const Eigen::Vector3d P(0.3, -0.2, 2.5);
  BaRgbdError cost(Eigen::Vector2d(300, 250), streakSqrtInformation(Eigen::Vector2d(9.0, -4.0), 1.44), testPinhole(),
                   2.4, 0.08 * 525.0, 1.44, 2.0);
  test::expectJacobiansMatch(cost, {quat(T_cw), vec(T_cw.translation()), vec(P)});
}

/// The block's squared norm is the Huber cost of its pixel part plus that of its depth part,
/// each with its own width test: what a pixel block and a depth block with a HuberLoss each cost.
/// Inside the width the rows are the raw residuals.
TEST(BaRgbdError, SquaredNormIsTheHuberCostOfEachPart) {
  const Eigen::Isometry3d T_cw = makePose(0.1, -0.2, 0.3, 0.05, -0.1, 0.2);
  const Eigen::Vector3d P(0.3, -0.2, 2.5);
  std::vector<double> q = quat(T_cw), t = vec(T_cw.translation()), p = vec(P);
  const double* parameters[] = {q.data(), t.data(), p.data()};
  const Eigen::Vector2d uv_true = testPinhole().project(T_cw * P);
  const double depth_true = (T_cw * P).z();
  const double huber = 2.0;
  const auto rho = [&](double s) { return s <= huber * huber ? s : 2.0 * huber * std::sqrt(s) - huber * huber; };
  // (pixel offset [px], depth [m]): both inside, pixel outside only, depth outside only, both.
  for (const auto& [offset_px, depth_m] : std::vector<std::pair<double, double>>{
           {0.5, depth_true + 0.002}, {12.0, depth_true + 0.002}, {0.5, depth_true + 0.3}, {12.0, depth_true + 0.3}}) {
    BaRgbdError cost(uv_true + Eigen::Vector2d(offset_px, 0.0), Eigen::Matrix2d::Identity(), testPinhole(), depth_m,
                     0.08 * 525.0, 1.0, huber);
    double raw[3], scaled[3];
    ASSERT_TRUE(cost.rawResiduals(parameters, raw));
    ASSERT_TRUE(cost.Evaluate(parameters, scaled, nullptr));
    EXPECT_NEAR(std::abs(raw[0]), offset_px, 1e-9);
    const double s_px = raw[0] * raw[0] + raw[1] * raw[1];
    const double s_d = raw[2] * raw[2];
    EXPECT_NEAR(scaled[0] * scaled[0] + scaled[1] * scaled[1], rho(s_px), 1e-9 * (1.0 + rho(s_px)));
    EXPECT_NEAR(scaled[2] * scaled[2], rho(s_d), 1e-9 * (1.0 + rho(s_d)));
    if (s_px <= huber * huber) {
      EXPECT_EQ(scaled[0], raw[0]);
    }
    if (s_d <= huber * huber) {
      EXPECT_EQ(scaled[2], raw[2]);
    } else {
      EXPECT_LT(std::abs(scaled[2]), std::abs(raw[2]));
    }
  }
}

/// Without a measured depth the third row is 0 and moves with nothing; the pixel rows are those
/// with a depth.
TEST(BaRgbdError, WithoutDepthTheThirdRowIsZero) {
  const Eigen::Isometry3d T_cw = makePose(0.1, -0.2, 0.3, 0.05, -0.1, 0.2);
  const Eigen::Vector3d P(0.3, -0.2, 2.5);
  const Eigen::Matrix2d W = Eigen::Matrix2d::Identity() / 1.2;
  BaRgbdError without(Eigen::Vector2d(300, 250), W, testPinhole(), 0.0, 0.08 * 525.0, 1.2, 2.0);
  BaRgbdError with(Eigen::Vector2d(300, 250), W, testPinhole(), 2.4, 0.08 * 525.0, 1.2, 2.0);
  std::vector<double> q = quat(T_cw), t = vec(T_cw.translation()), p = vec(P);
  const double* parameters[] = {q.data(), t.data(), p.data()};
  double r_without[3], r_with[3], J_q[12], J_t[9], J_p[9];
  double* jacobians[] = {J_q, J_t, J_p};
  ASSERT_TRUE(without.Evaluate(parameters, r_without, jacobians));
  ASSERT_TRUE(with.Evaluate(parameters, r_with, nullptr));
  EXPECT_EQ(r_without[2], 0.0);
  EXPECT_NE(r_with[2], 0.0);
  EXPECT_EQ(r_without[0], r_with[0]);
  EXPECT_EQ(r_without[1], r_with[1]);
  for (int c = 0; c < 4; ++c) EXPECT_EQ(J_q[8 + c], 0.0);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(J_t[6 + c], 0.0);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(J_p[6 + c], 0.0);
  test::expectJacobiansMatch(without, {q, t, p});
}

TEST(BaRelativePoseError, JacobiansMatchCentralDifferences) {
  const Eigen::Isometry3d T_a = makePose(0.1, -0.2, 0.3, 0.05, -0.1, 0.2);  // T_camera_world of a
  const Eigen::Isometry3d T_b = makePose(-0.2, 0.1, 0.25, 0.3, 0.1, -0.1);
  const Eigen::Isometry3d T_a_b_meas = makePose(0.05, -0.02, 0.01, 0.1, 0.02, -0.03);
  std::unique_ptr<ceres::CostFunction> cost(newBaRelativePoseError(T_a_b_meas, 0.01, 0.02));
  test::expectJacobiansMatch(*cost, {quat(T_a), vec(T_a.translation()), quat(T_b), vec(T_b.translation())});
}

/// Zero where X_a X_b^-1 equals the measurement, whichever sign the quaternions are stored with;
/// 0.5 deg and 1 cm off read 1 sigma each (with sigmas 0.5 deg, 1 cm).
TEST(BaRelativePoseError, ZeroAtTheMeasurementAndOneSigmaOff) {
  const Eigen::Isometry3d T_a = makePose(0.2, 0.1, -0.3, 1.0, 0.5, -0.2);
  const Eigen::Isometry3d T_b = makePose(-0.1, 0.4, 0.2, 1.3, 0.2, 0.1);
  const Eigen::Isometry3d T_a_b = T_a * T_b.inverse();
  const double sigma_rot = 0.5 * M_PI / 180.0;
  std::unique_ptr<ceres::CostFunction> cost(newBaRelativePoseError(T_a_b, sigma_rot, 0.01));
  std::vector<double> q_b = quat(T_b);
  for (double& c : q_b) c = -c;  // the same rotation
  // Residuals with keyframe a at T_camera_world_a, b as above.
  const auto residuals = [&](const Eigen::Isometry3d& T_camera_world_a) {
    const std::vector<std::vector<double>> p{quat(T_camera_world_a), vec(T_camera_world_a.translation()), q_b,
                                             vec(T_b.translation())};
    const double* ptrs[] = {p[0].data(), p[1].data(), p[2].data(), p[3].data()};
    Eigen::Matrix<double, 6, 1> r;
    EXPECT_TRUE(cost->Evaluate(ptrs, r.data(), nullptr));
    return r;
  };
  const Eigen::Matrix<double, 6, 1> at_measurement = residuals(T_a);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(at_measurement[i], 0.0, 1e-9);
  // a 1 cm off along its own x (X_a moved: t_ab changes by 1 cm in a's frame).
  const Eigen::Matrix<double, 6, 1> shifted = residuals(makePose(0, 0, 0, 0.01, 0, 0) * T_a);
  EXPECT_NEAR(shifted.tail<3>().norm(), 1.0, 1e-6);
  EXPECT_NEAR(shifted.head<3>().norm(), 0.0, 1e-9);
  // a turned by 0.5 deg: the rotation part reads 1 (2 sin(theta / 2) / sigma, 1 to 1e-5).
  EXPECT_NEAR(residuals(makePose(sigma_rot, 0, 0, 0, 0, 0) * T_a).head<3>().norm(), 1.0, 1e-5);
}

TEST(PoseGraphError, JacobiansMatchCentralDifferences) {
  const Eigen::Isometry3d T_a = makePose(0.2, 0.1, -0.3, 1.0, 0.5, -0.2);
  const Eigen::Isometry3d T_b = makePose(-0.1, 0.4, 0.2, 1.3, 0.2, 0.1);
  const Eigen::Isometry3d T_ab_meas = makePose(-0.25, 0.3, 0.45, 0.2, -0.3, 0.35);
  PoseGraphError cost(T_ab_meas, 0.01, 0.02);
  test::expectJacobiansMatch(cost, {quat(T_a), vec(T_a.translation()), quat(T_b), vec(T_b.translation())});
}

TEST(PoseGraphError, ZeroAtTheMeasurement) {
  const Eigen::Isometry3d T_a = makePose(0.2, 0.1, -0.3, 1.0, 0.5, -0.2);
  const Eigen::Isometry3d T_b = makePose(-0.1, 0.4, 0.2, 1.3, 0.2, 0.1);
  PoseGraphError cost(T_a.inverse() * T_b, 0.01, 0.01);
  std::vector<std::vector<double>> p{quat(T_a), vec(T_a.translation()), quat(T_b), vec(T_b.translation())};
  const double* ptrs[] = {p[0].data(), p[1].data(), p[2].data(), p[3].data()};
  double r[6];
  ASSERT_TRUE(cost.Evaluate(ptrs, r, nullptr));
  for (double v : r) EXPECT_NEAR(v, 0.0, 1e-9);
}

/// A loop of 24 poses on a circle; odometry edges are exact but the initial poses drift (a yaw
/// error of 0.5 deg per step accumulates to 12 deg); the loop edge last -> first is exact.
TEST(PoseGraphOptimizer, LoopEdgeRemovesAccumulatedDrift) {
  constexpr int kN = 24;
  std::map<std::int64_t, Eigen::Isometry3d> truth, drifted;
  for (int i = 0; i < kN; ++i) {
    const double a = 2 * M_PI * i / kN;
    truth[i] = makePose(0, 0, a, 2 * std::cos(a), 2 * std::sin(a), 0);
  }
  std::vector<PoseGraphEdge> edges;
  drifted[0] = truth[0];
  const Eigen::Isometry3d drift = makePose(0, 0, 0.5 * M_PI / 180, 0, 0, 0);
  for (int i = 1; i < kN; ++i) {
    const Eigen::Isometry3d rel = truth[i - 1].inverse() * truth[i];
    edges.push_back({i - 1, i, rel, 1.0});
    drifted[i] = drifted[i - 1] * drift * rel;
  }
  edges.push_back({0, kN - 1, truth[0].inverse() * truth[kN - 1], 1.0});
  double before = 0, after = 0;
  TrackingOptions options;
  const PoseGraphResult r = PoseGraphOptimizer(options).optimize(drifted, edges, 0);
  ASSERT_TRUE(r.success) << r.message;
  for (int i = 0; i < kN; ++i) {
    before = std::max(before, (drifted[i].translation() - truth[i].translation()).norm());
    after = std::max(after, (r.T_world_keyframe.at(i).translation() - truth[i].translation()).norm());
  }
  // Drifted: the last poses are ~0.4 m off. All edges are consistent with the truth, so the
  // optimum is the truth; 1 mm allows for LM stopping tolerances.
  EXPECT_GT(before, 0.2);
  EXPECT_LT(after, 1e-3);
  EXPECT_LT(r.final_cost, 1e-6 * r.initial_cost);
}

/// Twelve keyframes on a circle; tracking was lost after keyframe 5, and keyframe 6 started a
/// re-initialised segment at keyframe 5's pose (the motion while lost unknown): keyframes 6-11
/// are the truth moved by the camera's 25 deg turn and 0.5 m step it missed. A loop from keyframe 11
/// back to keyframe 0 measures keyframe 11's true pose.
class LoopAcrossAGuess : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int i = 0; i < kN; ++i) {
      const double a = 1.5 * M_PI * i / (kN - 1);
      truth_[i] = makePose(0, 0, a, 2 * std::cos(a), 2 * std::sin(a), 0);
    }
    // The guess: keyframe 6 where keyframe 5 was; the segment rigid behind it.
    const Eigen::Isometry3d T_guess_truth = truth_[5] * truth_[6].inverse();
    for (int i = 0; i < kN; ++i) {
      MapKeyframe kf;
      kf.id = i;
      kf.T_world_camera = i < kFirstGuessed ? truth_[i] : T_guess_truth * truth_[i];
      map_.addKeyframe(std::move(kf));
    }
    loop_.found = true;
    loop_.current_keyframe_id = kN - 1;
    loop_.loop_keyframe_id = 0;
    loop_.T_world_current = truth_[kN - 1];
  }
  /// Largest distance of a keyframe from the truth [m].
  double worstError() const {
    double worst = 0;
    for (int i = 0; i < kN; ++i) {
      worst = std::max(worst, (map_.keyframe(i)->T_world_camera.translation() - truth_.at(i).translation()).norm());
    }
    return worst;
  }
  static constexpr int kN = 12;
  static constexpr int kFirstGuessed = 6;
  TrackingOptions options_;
  TrackerMap map_{options_};
  std::map<std::int64_t, Eigen::Isometry3d> truth_;
  LoopResult loop_;
};

TEST_F(LoopAcrossAGuess, TheLoopPlacesTheSegmentWhoseStartWasGuessed) {
  ASSERT_GT(worstError(), 0.4);  // the guess is off by the missed 0.5 m step and 25 deg turn
  const LoopCorrection c = LoopCloser(options_).close(&map_, loop_, kFirstGuessed);
  ASSERT_TRUE(c.applied) << c.message;
  // Without the edge from the guess, every edge agrees with the truth: the optimum is the truth
  // (1 mm for the solver's stopping tolerances, as in LoopEdgeRemovesAccumulatedDrift).
  EXPECT_LT(worstError(), 1e-3);
}

TEST_F(LoopAcrossAGuess, WithTheGuessAsAnEdgeTheSegmentStaysOff) {
  // The same loop, closed as if keyframe 6's pose had been measured: the guess and the loop
  // disagree by the whole missed motion, and the graph splits it (what the closer did before).
  const LoopCorrection c = LoopCloser(options_).close(&map_, loop_);
  ASSERT_TRUE(c.applied) << c.message;
  EXPECT_GT(worstError(), 0.05);
}

/// Synthetic map: 4 keyframes observing 300 points; the two newest keyframes' poses and all
/// points are perturbed; local BA with the two oldest fixed must recover the poses.
/// The local BA tests' scene: 300 points 2-4 m in front of the first camera, 3 m across.
std::vector<Eigen::Vector3d> wallPoints(std::mt19937& rng) {
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uz(2.0, 4.0);
  std::vector<Eigen::Vector3d> points(300);
  for (auto& p : points) p = Eigen::Vector3d(ux(rng), 0.7 * ux(rng), uz(rng));
  return points;
}

/// The local BA tests' four keyframes: 30 cm sideways, turning up to 5 deg.
std::vector<Eigen::Isometry3d> arcPoses() {
  return {makePose(0, 0, 0, 0, 0, 0), makePose(0, 0.03, 0, 0.1, 0, 0), makePose(0.02, 0.05, 0, 0.2, 0.02, 0),
          makePose(0.0, 0.08, 0.01, 0.3, 0.0, 0.05)};
}

TEST(LocalBundleAdjuster, RecoversPerturbedKeyframesAndPoints) {
  std::mt19937 rng(3);
  std::normal_distribution<double> pix(0.0, 0.5), pos(0.0, 0.03);
  const std::vector<Eigen::Vector3d> points = wallPoints(rng);
  const std::vector<Eigen::Isometry3d> truth = arcPoses();
  TrackingOptions options;
  options.local_ba_keyframes = 2;  // free: newest + its most covisible (the 3rd)
  options.local_ba_iterations = 20;
  options.cull_min_found_ratio = 0;
  TrackerMap map(options);
  const Pinhole pin = testPinhole();
  cv::Mat desc(static_cast<int>(points.size()), 32, CV_8UC1, cv::Scalar(0));
  for (size_t k = 0; k < truth.size(); ++k) {
    MapKeyframe kf;
    kf.id = static_cast<std::int64_t>(k);
    // Points are created from the first keyframe's (noisy) depth; later keyframes observe them.
    kf.T_world_camera = truth[k];
    if (k >= 2) kf.T_world_camera = truth[k] * makePose(0.01, -0.01, 0.005, 0.03, -0.02, 0.02);
    for (size_t j = 0; j < points.size(); ++j) {
      const Eigen::Vector3d p_c = truth[k].inverse() * points[j];
      Eigen::Vector2d uv = pin.project(p_c) + Eigen::Vector2d(pix(rng), pix(rng));
      cv::KeyPoint kp(static_cast<float>(uv.x()), static_cast<float>(uv.y()), 31.f);
      kp.octave = 0;
      kf.features.keypoints.push_back(kp);
      kf.features.uv_undistorted_px.push_back(uv);
      kf.features.depth_m.push_back(static_cast<float>(p_c.z()));
      kf.features.p_camera_m.push_back(p_c + Eigen::Vector3d(pos(rng), pos(rng), pos(rng)));
      kf.map_point_ids.push_back(static_cast<std::int64_t>(j));
    }
    kf.features.descriptors = desc.clone();
    map.addKeyframe(std::move(kf));
  }
  double mean_error_before = 0;
  for (size_t j = 0; j < points.size(); ++j) {
    mean_error_before += (map.point(static_cast<std::int64_t>(j))->p_world_m - points[j]).norm();
  }
  ASSERT_EQ(map.points().size(), points.size());
  EXPECT_EQ(map.covisibleKeyframes(3, 10).size(), 3u);
  const LocalBaResult r = LocalBundleAdjuster(options).adjust(&map, 3, pin);
  ASSERT_TRUE(r.ran) << r.message;
  EXPECT_EQ(r.optimized_keyframes, 2);
  EXPECT_EQ(r.fixed_keyframes, 2);
  for (std::int64_t k : {2, 3}) {
    const Eigen::Isometry3d err = truth[static_cast<size_t>(k)].inverse() * map.keyframe(k)->T_world_camera;
    // Perturbation was 3-4 cm / 0.7 deg; with 0.5 px noise over 300 points BA lands within
    // a few mm (measured ~1 mm); 1 cm and 0.2 deg show that it moved most of the way back.
    EXPECT_LT(err.translation().norm(), 0.01) << "keyframe " << k;
    EXPECT_LT(Eigen::AngleAxisd(err.rotation()).angle() * 180 / M_PI, 0.2) << "keyframe " << k;
  }
  // Fixed keyframes do not move.
  EXPECT_TRUE(map.keyframe(0)->T_world_camera.isApprox(truth[0], 1e-12));
  // Points move towards the truth: the lateral part of the 3 cm (per axis) noise is well
  // constrained by four views, the depth part only by the 0.3 m baseline (~3 cm at 3 m for
  // 0.5 px), so ask for a clear reduction (to < 70 %) rather than an absolute bound.
  double mean_error = 0;
  for (size_t j = 0; j < points.size(); ++j) {
    mean_error += (map.point(static_cast<std::int64_t>(j))->p_world_m - points[j]).norm();
  }
  EXPECT_LT(mean_error, 0.7 * mean_error_before);
}

/// The newest of four keyframes was taken in a fast turn about the camera's y axis: its
/// keypoints lie anywhere on horizontal streaks 16 px long (uniform along, 0.3 px across).
/// Local BA with that keyframe's blur (MapKeyframe::blur_rates, blur_exposure_s, the weights of
/// motion_blur.h) must place it closer to the truth than the same BA that takes its keypoints as
/// sharp: the streaks are then noise it trusts as much as the sharp keyframes' 0.3 px.
double blurredKeyframeErrorM(bool with_blur_weights) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> along(-8.0, 8.0);
  std::normal_distribution<double> pix(0.0, 0.3);
  const std::vector<Eigen::Vector3d> points = wallPoints(rng);
  const std::vector<Eigen::Isometry3d> truth = arcPoses();
  CameraRates turn;
  turn.omega_rad_s = Eigen::Vector3d(0.0, 2.0, 0.0);  // 115 deg/s about y: streaks along the rows
  const double exposure_s = 0.015;                    // 2 rad/s x 525 px x 15 ms: 15.75 px at the centre
  TrackingOptions options;
  options.local_ba_keyframes = 2;  // free: the blurred newest keyframe and the 3rd; the two oldest fixed
  options.local_ba_iterations = 20;
  options.local_ba_depth_baseline_m = 0.0;  // the pixels alone
  options.cull_min_found_ratio = 0;
  TrackerMap map(options);
  const Pinhole pin = testPinhole();
  cv::Mat desc(static_cast<int>(points.size()), 32, CV_8UC1, cv::Scalar(0));
  for (size_t k = 0; k < truth.size(); ++k) {
    const bool blurred = k == 3;
    MapKeyframe kf;
    kf.id = static_cast<std::int64_t>(k);
    kf.T_world_camera = blurred ? truth[k] * makePose(0.004, -0.006, 0.002, 0.02, -0.01, 0.01) : truth[k];
    if (blurred && with_blur_weights) {
      kf.blur_rates = turn;
      kf.blur_exposure_s = exposure_s;
    }
    for (size_t j = 0; j < points.size(); ++j) {
      const Eigen::Vector3d p_c = truth[k].inverse() * points[j];
      Eigen::Vector2d uv = pin.project(p_c) + Eigen::Vector2d(pix(rng), pix(rng));
      if (blurred) uv.x() += along(rng);
      cv::KeyPoint kp(static_cast<float>(uv.x()), static_cast<float>(uv.y()), 31.f);
      kp.octave = 0;
      kf.features.keypoints.push_back(kp);
      kf.features.uv_undistorted_px.push_back(uv);
      kf.features.depth_m.push_back(static_cast<float>(p_c.z()));
      kf.features.p_camera_m.push_back(p_c);
      kf.map_point_ids.push_back(static_cast<std::int64_t>(j));
    }
    kf.features.descriptors = desc.clone();
    map.addKeyframe(std::move(kf));
  }
  const LocalBaResult r = LocalBundleAdjuster(options).adjust(&map, 3, pin);
  EXPECT_TRUE(r.ran) << r.message;
  EXPECT_EQ(r.optimized_keyframes, 2);
  return (truth[3].inverse() * map.keyframe(3)->T_world_camera).translation().norm();
}

TEST(LocalBundleAdjuster, ABlurredKeyframeGivesWayAlongItsStreaks) {
  const double weighted_m = blurredKeyframeErrorM(true);
  const double as_sharp_m = blurredKeyframeErrorM(false);
  std::cout << "blurred keyframe after local BA: " << weighted_m * 100 << " cm weighted, " << as_sharp_m * 100
            << " cm as sharp\n";
  // Measured: 0.27 cm weighted, 2.48 cm as sharp (the same from an unperturbed start: the
  // streaks' noise, along x, moves the keyframe along the direction a turn about y trades with a
  // sideways step). The weights must take at least a third off.
  EXPECT_LT(weighted_m, 0.67 * as_sharp_m) << "weighted " << weighted_m << " m, as sharp " << as_sharp_m << " m";
}

/// Four keyframes on a short arc seeing 300 points 2-4 m away (0.5 px noise); keyframes 2 and 3
/// start 2-4 cm off. With `single_view_points`, the newest keyframe also sees 20 points that no
/// other keyframe sees (ids from 1000, exact camera coordinates).
void buildFourKeyframes(bool single_view_points, TrackerMap* map) {
  std::mt19937 rng(11);
  std::normal_distribution<double> pix(0.0, 0.5);
  const std::vector<Eigen::Vector3d> points = wallPoints(rng);
  const std::vector<Eigen::Isometry3d> truth = arcPoses();
  const Pinhole pin = testPinhole();
  auto observe = [&](const Eigen::Vector3d& p_c, const Eigen::Vector2d& uv, std::int64_t id, MapKeyframe* kf) {
    cv::KeyPoint kp(static_cast<float>(uv.x()), static_cast<float>(uv.y()), 31.f);
    kp.octave = 0;
    kf->features.keypoints.push_back(kp);
    kf->features.uv_undistorted_px.push_back(uv);
    kf->features.depth_m.push_back(static_cast<float>(p_c.z()));
    kf->features.p_camera_m.push_back(p_c);
    kf->map_point_ids.push_back(id);
  };
  for (size_t k = 0; k < truth.size(); ++k) {
    MapKeyframe kf;
    kf.id = static_cast<std::int64_t>(k);
    kf.T_world_camera = k >= 2 ? truth[k] * makePose(0.01, -0.01, 0.005, 0.03, -0.02, 0.02) : truth[k];
    for (size_t j = 0; j < points.size(); ++j) {
      const Eigen::Vector3d p_c = truth[k].inverse() * points[j];
      observe(p_c, pin.project(p_c) + Eigen::Vector2d(pix(rng), pix(rng)), static_cast<std::int64_t>(j), &kf);
    }
    for (int i = 0; single_view_points && k == 3 && i < 20; ++i) {
      const Eigen::Vector3d p_c(-0.5 + 0.05 * i, 0.2, 2.5);
      observe(p_c, pin.project(p_c), 1000 + i, &kf);
    }
    kf.features.descriptors = cv::Mat(static_cast<int>(kf.map_point_ids.size()), 32, CV_8UC1, cv::Scalar(0));
    map->addKeyframe(std::move(kf));
  }
}

/// A point that only one keyframe of the window sees fits its observation wherever that keyframe
/// goes: it is left out of the problem and moves rigidly with the keyframe (its camera coordinates
/// there unchanged), and the poses are those of the same window without it.
TEST(LocalBundleAdjuster, PointsSeenByOneKeyframeMoveWithIt) {
  TrackingOptions options;
  options.local_ba_keyframes = 2;  // free: the newest and the 3rd; the two oldest fixed
  options.cull_min_found_ratio = 0;
  TrackerMap map(options), without(options);
  buildFourKeyframes(true, &map);
  buildFourKeyframes(false, &without);
  const LocalBundleAdjuster adjuster(options);
  const LocalBaProblem problem = adjuster.prepare(map, 3, testPinhole());
  ASSERT_TRUE(problem.message.empty()) << problem.message;
  EXPECT_EQ(problem.p_world_m.size(), 300u);
  ASSERT_EQ(problem.single_view_points.size(), 20u);
  for (const SingleViewPoint& single : problem.single_view_points) EXPECT_EQ(single.keyframe_id, 3);

  const Eigen::Isometry3d T_before = map.keyframe(3)->T_world_camera;
  std::vector<Eigen::Vector3d> p_camera_before;
  for (int i = 0; i < 20; ++i) p_camera_before.push_back(T_before.inverse() * map.point(1000 + i)->p_world_m);
  ASSERT_TRUE(adjuster.adjust(&map, 3, testPinhole()).ran);
  ASSERT_TRUE(adjuster.adjust(&without, 3, testPinhole()).ran);
  const Eigen::Isometry3d T_after = map.keyframe(3)->T_world_camera;
  ASSERT_GT((T_after.translation() - T_before.translation()).norm(), 0.005);  // the keyframe moved
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d p_camera_after = T_after.inverse() * map.point(1000 + i)->p_world_m;
    EXPECT_LT((p_camera_after - p_camera_before[static_cast<size_t>(i)]).norm(), 1e-9) << "point " << i;
  }
  for (std::int64_t k : {2, 3}) {
    EXPECT_TRUE(map.keyframe(k)->T_world_camera.isApprox(without.keyframe(k)->T_world_camera, 1e-12)) << k;
  }
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
