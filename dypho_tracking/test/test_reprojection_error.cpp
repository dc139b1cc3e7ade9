#include <random>
#include <string>
#include <vector>

#include <ceres/manifold.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "dypho/tracking/reprojection_error.h"
#include "dypho/tracking/rolling_shutter_error.h"
#include "jacobian_check.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

using Mat24 = Eigen::Matrix<double, 2, 4, Eigen::RowMajor>;
using Mat23 = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;

const Pinhole kPinhole{517.3, 516.5, 318.6, 255.3};

/// Analytic vs central-difference Jacobian in the ambient coordinates (q: 4, t: 3).
/// Tolerance: relative Frobenius error < 1e-6. With step h = 1e-6 the truncation error is
/// O(h^2 |r'''|) ~ 1e-9 and the round-off error eps |r| / h ~ 1e-16 * 1e3 / 1e-6 = 1e-7 absolute
/// against Jacobian entries of order 1e2..1e3, i.e. ~1e-9 relative: 1e-6 leaves a wide margin
/// while still catching any wrong sign or factor (those give errors of order 1).
TEST(ReprojectionError, AnalyticJacobianMatchesCentralDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.5 * uni(rng), Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized()));
    Eigen::Vector3d t(0.3 * uni(rng), 0.3 * uni(rng), 0.3 * uni(rng));
    const Eigen::Vector3d p_c(uni(rng), uni(rng), 2.5 + uni(rng));
    const Eigen::Vector3d p_w = q.inverse() * (p_c - t);
    const double sigma = 1.2 * (1 + trial % 3);
    const ReprojectionError cost(p_w, Eigen::Vector2d(300 + 20 * uni(rng), 200), sigma, kPinhole);

    double qd[4] = {q.x(), q.y(), q.z(), q.w()};
    double td[3] = {t.x(), t.y(), t.z()};
    const double* params[2] = {qd, td};
    Mat24 J_q;
    Mat23 J_t;
    double* jac[2] = {J_q.data(), J_t.data()};
    Eigen::Vector2d r;
    ASSERT_TRUE(cost.Evaluate(params, r.data(), jac));

    const double h = 1e-6;
    Mat24 N_q;
    Mat23 N_t;
    for (int k = 0; k < 7; ++k) {
      double* x = k < 4 ? &qd[k] : &td[k - 4];
      const double x0 = *x;
      Eigen::Vector2d rp, rm;
      *x = x0 + h;
      ASSERT_TRUE(cost.Evaluate(params, rp.data(), nullptr));
      *x = x0 - h;
      ASSERT_TRUE(cost.Evaluate(params, rm.data(), nullptr));
      *x = x0;
      const Eigen::Vector2d d = (rp - rm) / (2 * h);
      if (k < 4) {
        N_q.col(k) = d;
      } else {
        N_t.col(k - 4) = d;
      }
    }
    EXPECT_LT((J_q - N_q).norm() / J_q.norm(), 1e-6) << "trial " << trial << "\n" << J_q << "\n" << N_q;
    EXPECT_LT((J_t - N_t).norm() / J_t.norm(), 1e-6) << "trial " << trial;

    // Tangent-space check through the manifold Ceres uses: J_q * PlusJacobian must equal the
    // central difference of r(q [+] delta) (same 1e-6 tolerance and reasoning).
    ceres::EigenQuaternionManifold manifold;
    Eigen::Matrix<double, 4, 3, Eigen::RowMajor> plus_jac;
    ASSERT_TRUE(manifold.PlusJacobian(qd, plus_jac.data()));
    const Eigen::Matrix<double, 2, 3> J_tangent = J_q * plus_jac;
    Eigen::Matrix<double, 2, 3> N_tangent;
    for (int k = 0; k < 3; ++k) {
      double delta[3] = {0, 0, 0};
      double qp[4], qm[4];
      delta[k] = h;
      manifold.Plus(qd, delta, qp);
      delta[k] = -h;
      manifold.Plus(qd, delta, qm);
      Eigen::Vector2d rp, rm;
      const double* pp[2] = {qp, td};
      const double* pm[2] = {qm, td};
      ASSERT_TRUE(cost.Evaluate(pp, rp.data(), nullptr));
      ASSERT_TRUE(cost.Evaluate(pm, rm.data(), nullptr));
      N_tangent.col(k) = (rp - rm) / (2 * h);
    }
    EXPECT_LT((J_tangent - N_tangent).norm() / J_tangent.norm(), 1e-6) << "trial " << trial;
  }
}

/// Same check for the 3-row RGB-D residual (u, v, u - b fx / z); same tolerance and reasoning.
TEST(RgbdReprojectionError, AnalyticJacobianMatchesCentralDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.5 * uni(rng), Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized()));
    const Eigen::Vector3d t(0.3 * uni(rng), 0.3 * uni(rng), 0.3 * uni(rng));
    const Eigen::Vector3d p_c(uni(rng), uni(rng), 2.5 + uni(rng));
    const Eigen::Vector3d p_w = q.inverse() * (p_c - t);
    const RgbdReprojectionError cost(p_w, Eigen::Vector2d(310, 240), 2.4 + 0.3 * uni(rng), 0.075, 1.2, kPinhole);
    double qd[4] = {q.x(), q.y(), q.z(), q.w()};
    double td[3] = {t.x(), t.y(), t.z()};
    const double* params[2] = {qd, td};
    Eigen::Matrix<double, 3, 4, Eigen::RowMajor> J_q, N_q;
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> J_t, N_t;
    double* jac[2] = {J_q.data(), J_t.data()};
    Eigen::Vector3d r;
    ASSERT_TRUE(cost.Evaluate(params, r.data(), jac));
    const double h = 1e-6;
    for (int k = 0; k < 7; ++k) {
      double* x = k < 4 ? &qd[k] : &td[k - 4];
      const double x0 = *x;
      Eigen::Vector3d rp, rm;
      *x = x0 + h;
      ASSERT_TRUE(cost.Evaluate(params, rp.data(), nullptr));
      *x = x0 - h;
      ASSERT_TRUE(cost.Evaluate(params, rm.data(), nullptr));
      *x = x0;
      const Eigen::Vector3d d = (rp - rm) / (2 * h);
      if (k < 4) {
        N_q.col(k) = d;
      } else {
        N_t.col(k - 4) = d;
      }
    }
    EXPECT_LT((J_q - N_q).norm() / J_q.norm(), 1e-6) << "trial " << trial;
    EXPECT_LT((J_t - N_t).norm() / J_t.norm(), 1e-6) << "trial " << trial;
  }
  // The third residual is zero exactly when the predicted depth equals the measured one.
  const Eigen::Vector3d p_w(0.1, 0.2, 2.0);
  const RgbdReprojectionError exact(p_w, kPinhole.project(p_w), 2.0, 0.075, 1.0, kPinhole);
  double qi[4] = {0, 0, 0, 1}, ti[3] = {0, 0, 0};
  const double* params[2] = {qi, ti};
  Eigen::Vector3d r;
  ASSERT_TRUE(exact.Evaluate(params, r.data(), nullptr));
  EXPECT_LT(r.norm(), 1e-9);
}

TEST(ReprojectionError, ResidualIsWhitenedPixelError) {
  const Eigen::Vector3d p_w(0.2, -0.1, 2.0);
  const ReprojectionError cost(p_w, Eigen::Vector2d(300, 250), 2.0, kPinhole);
  double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, 0};
  const double* params[2] = {q, t};
  Eigen::Vector2d r;
  ASSERT_TRUE(cost.Evaluate(params, r.data(), nullptr));
  const Eigen::Vector2d expected = (kPinhole.project(p_w) - Eigen::Vector2d(300, 250)) / 2.0;
  EXPECT_NEAR((r - expected).norm(), 0.0, 1e-12);
  // Behind the camera: the residual is rejected, not evaluated.
  t[2] = -3.0;
  EXPECT_FALSE(cost.Evaluate(params, r.data(), nullptr));
}

/// The rolling-shutter residual's analytic Jacobian (4 blocks: q, t, omega, v) against central
/// differences (jacobian_check.h, its tolerance and reasoning), with and without the depth row
/// and with a blurred keypoint's anisotropic W. Rates up to 6 rad/s and 1 m/s over row times up
/// to +-16 ms (a fast hand-held turn), and zero rates (the rotation's series branch); a wrong
/// sign or factor in any block gives an error of order 1.
TEST(RollingShutterReprojectionError, AnalyticJacobianMatchesCentralDifferences) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 60; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Eigen::Quaterniond q = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.5 * uni(rng), Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized()));
    const Eigen::Vector3d t(0.3 * uni(rng), 0.3 * uni(rng), 0.3 * uni(rng));
    const Eigen::Vector3d p_c(uni(rng), uni(rng), 2.5 + uni(rng));
    const Eigen::Vector3d p_w = q.inverse() * (p_c - t);
    const bool still = trial % 5 == 0;
    const double rate_scale = still ? 0.0 : 1.0;
    const std::vector<double> omega{6 * rate_scale * uni(rng), 6 * rate_scale * uni(rng), 6 * rate_scale * uni(rng)};
    const std::vector<double> velocity{rate_scale * uni(rng), rate_scale * uni(rng), rate_scale * uni(rng)};
    const double row_time_s = 0.016 * uni(rng);
    const double depth_m = trial % 2 == 0 ? 2.4 + 0.3 * uni(rng) : 0.0;  // odd trials: no depth row
    Eigen::Matrix2d W;
    W << 0.8, 0.3 * uni(rng), 0.0, 0.5;
    W = (0.5 * (W + W.transpose())).eval();  // symmetric, positive definite (diagonally dominant)
    const RollingShutterReprojectionError cost(p_w, Eigen::Vector2d(310 + 30 * uni(rng), 240), depth_m, 0.075 * 517.3,
                                               1.2, W, row_time_s, kPinhole);
    const std::vector<double> q_xyzw{q.x(), q.y(), q.z(), q.w()}, t_m{t.x(), t.y(), t.z()};
    test::expectJacobiansMatch(cost, {q_xyzw, t_m, omega, velocity});
    if (depth_m == 0.0) {
      const double* params[4] = {q_xyzw.data(), t_m.data(), omega.data(), velocity.data()};
      Eigen::Vector3d r;
      ASSERT_TRUE(cost.Evaluate(params, r.data(), nullptr));
      EXPECT_EQ(r.z(), 0.0) << "no depth row without a depth";
    }
  }
}

/// The rotation behind pointAtRowTime against Eigen's angle-axis, on both sides of its series
/// branch (1e-4 rad); 1e-12 is a few ulps of entries of order 1.
TEST(RollingShutterReprojectionError, AngleAxisRotationMatchesEigen) {
  for (const double angle : {0.0, 1e-9, 5e-5, 2e-4, 0.1, 1.0, 3.0}) {
    const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
    Eigen::Matrix3d R;
    angleAxisRotation(angle * axis, &R);
    EXPECT_LT((R - Eigen::AngleAxisd(angle, axis).toRotationMatrix()).norm(), 1e-12) << "angle " << angle;
  }
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
