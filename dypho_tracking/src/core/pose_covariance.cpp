#include "dypho/tracking/pose_covariance.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <ceres/cost_function.h>
#include <ceres/manifold.h>

namespace dypho {
namespace tracking {

namespace {

/// The solve's unknowns on their tangent: a left turn d of T_camera_world's rotation (R' = exp(d)
/// R) [rad], its translation [m], and with a rolling shutter omega [rad/s] and v [m/s].
constexpr int kPose = 6;
constexpr int kUnknowns = 12;
using Information = Eigen::Matrix<double, kUnknowns, kUnknowns>;

/// [t]x, the cross product with t as a matrix.
Eigen::Matrix3d skew(const Eigen::Vector3d& t) {
  Eigen::Matrix3d m;
  m << 0.0, -t.z(), t.y(), t.z(), 0.0, -t.x(), -t.y(), t.x(), 0.0;
  return m;
}

/// The Gauss-Newton information H = sum J^T J of the solve's residuals at the estimate (the
/// velocities' priors not yet in it), their chi2 and the number of their measured residuals (2 per
/// observation, 3 with a depth residual). Observations Ceres cannot evaluate (behind the camera)
/// are left out.
struct Accumulated {
  Information H = Information::Zero();
  double chi2 = 0.0;
  int residuals = 0;
  int points = 0;
};

Accumulated accumulate(const PoseCosts& costs, const std::vector<PoseObservation>& inliers,
                       const Eigen::Isometry3d& T_camera_world, const CameraRates& rates) {
  Accumulated out;
  Eigen::Quaterniond q(T_camera_world.rotation());
  q.normalize();
  const Eigen::Vector3d t = T_camera_world.translation();
  CameraRates at = rates;
  const double* parameters[4] = {q.coeffs().data(), t.data(), at.omega_rad_s.data(), at.velocity_m_s.data()};
  // d q / d d of q' = exp(d) q: Ceres's quaternion tangent is half the turn's angle-axis.
  Eigen::Matrix<double, 4, 3, Eigen::RowMajor> dq_dd;
  ceres::EigenQuaternionManifold().PlusJacobian(q.coeffs().data(), dq_dd.data());
  dq_dd *= 0.5;
  Eigen::Matrix<double, 3, 4, Eigen::RowMajor> J_q;
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> J_t, J_omega, J_v;
  double* jacobians[4] = {J_q.data(), J_t.data(), J_omega.data(), J_v.data()};
  Eigen::Vector3d r;
  for (std::size_t i = 0; i < costs.observations.size(); ++i) {
    // A cost with 2 residuals fills the leading rows: the third stays zero.
    r.setZero();
    J_q.setZero();
    J_t.setZero();
    J_omega.setZero();
    J_v.setZero();
    if (!costs.observations[i]->Evaluate(parameters, r.data(), jacobians) || !r.allFinite()) continue;
    Eigen::Matrix<double, 3, kUnknowns> J = Eigen::Matrix<double, 3, kUnknowns>::Zero();
    J.leftCols<3>() = J_q * dq_dd;
    J.middleCols<3>(3) = J_t;
    if (costs.rolling) {
      J.middleCols<3>(6) = J_omega;
      J.rightCols<3>() = J_v;
    }
    if (!J.allFinite()) continue;
    out.H.noalias() += J.transpose() * J;
    out.chi2 += r.squaredNorm();
    out.residuals += hasDepthResidual(inliers[i], costs.bf_px_m) ? 3 : 2;
    ++out.points;
  }
  return out;
}

}  // namespace

PoseInformation featurePoseInformation(const PoseOptimizer& optimizer, const std::vector<PoseObservation>& inliers,
                                       const Pinhole& pinhole, const Eigen::Isometry3d& T_camera_world) {
  const PoseCosts costs = optimizer.costsAt(inliers, pinhole, T_camera_world, CameraRates(), 0.0);
  const PoseInformation H = accumulate(costs, inliers, T_camera_world, CameraRates()).H.topLeftCorner<kPose, kPose>();
  // T' = exp(v, w) T turns R by w and moves t to exp(w) t + v: (d, dt) = (w, v - [t]x w).
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  A.topRightCorner<3, 3>() = Eigen::Matrix3d::Identity();
  A.bottomLeftCorner<3, 3>() = Eigen::Matrix3d::Identity();
  A.bottomRightCorner<3, 3>() = -skew(T_camera_world.translation());
  return A.transpose() * H * A;
}

PoseCovariance poseCovariance(const PoseOptimizer& optimizer, const std::vector<PoseObservation>& inliers,
                              const Pinhole& pinhole, const Eigen::Isometry3d& T_camera_world, const CameraRates& rates,
                              const CameraRates& blur_rates, double exposure_s) {
  PoseCovariance out;
  const PoseCosts costs = optimizer.costsAt(inliers, pinhole, T_camera_world, blur_rates, exposure_s);
  const Accumulated a = accumulate(costs, inliers, T_camera_world, rates);
  if (a.points < 3 || !std::isfinite(a.chi2)) return out;
  // The pose's information with the velocities marginalised: H_pp - H_pr H_rr^-1 H_rp, H_rr
  // with the priors (never singular).
  PoseInformation H = a.H.topLeftCorner<kPose, kPose>();
  if (costs.rolling) {
    Eigen::Matrix<double, 6, 6> H_rr = a.H.bottomRightCorner<6, 6>();
    H_rr.topLeftCorner<3, 3>().diagonal().array() += 1.0 / (costs.omega_sigma_rad_s * costs.omega_sigma_rad_s);
    H_rr.bottomRightCorner<3, 3>().diagonal().array() += 1.0 / (costs.velocity_sigma_m_s * costs.velocity_sigma_m_s);
    const Eigen::Matrix<double, kPose, 6> H_pr = a.H.topRightCorner<kPose, 6>();
    H -= H_pr * H_rr.ldlt().solve(H_pr.transpose());
    H = 0.5 * (H + H.transpose());
  }
  const Eigen::SelfAdjointEigenSolver<PoseInformation> eigen(H);
  if (eigen.info() != Eigen::Success || !(eigen.eigenvalues()(0) > 1e-9 * eigen.eigenvalues()(5))) return out;
  out.variance_factor = a.residuals > 6 ? std::max(1.0, a.chi2 / (a.residuals - 6)) : 1.0;
  // Covariance of (d, dt): R' = exp(d) R, t' = t + dt for T_camera_world = (R, t).
  const PoseInformation covariance_tangent = out.variance_factor * eigen.eigenvectors() *
                                             eigen.eigenvalues().cwiseInverse().asDiagonal() *
                                             eigen.eigenvectors().transpose();
  // The centre c = -R^T t moves by -R^T dt - R^T [t]x d to first order, and R_world_camera' =
  // R^T exp(-d) turns by -R^T d about the world axes.
  const Eigen::Matrix3d Rt = T_camera_world.rotation().transpose();
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Zero();
  J.topLeftCorner<3, 3>() = -Rt * skew(T_camera_world.translation());
  J.topRightCorner<3, 3>() = -Rt;
  J.bottomLeftCorner<3, 3>() = -Rt;
  out.world = J * covariance_tangent * J.transpose();
  out.world = 0.5 * (out.world + out.world.transpose());
  out.valid = out.world.allFinite();
  if (!out.valid) out.world.setZero();
  return out;
}

double PoseCovariance::maxPositionSigmaM() const {
  if (!valid) return 0.0;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(world.topLeftCorner<3, 3>());
  return std::sqrt(std::max(0.0, eigen.eigenvalues()(2)));
}

}  // namespace tracking
}  // namespace dypho
