#include "dypho/tracking/pose_covariance.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace dypho {
namespace tracking {

PoseInformation featurePoseInformation(const std::vector<PoseObservation>& inliers, const Pinhole& pinhole,
                                       const Eigen::Isometry3d& T_camera_world, double scale_factor,
                                       double depth_baseline_m) {
  PoseInformation H = PoseInformation::Zero();
  const double bf = depth_baseline_m * pinhole.fx;
  for (const PoseObservation& o : inliers) {
    const Eigen::Vector3d q = T_camera_world * o.p_world_m;
    if (q.z() < 1e-3) continue;
    const double iz = 1.0 / q.z();
    const double sigma = std::pow(scale_factor, std::max(0, o.level));
    const double w = 1.0 / (sigma * sigma);
    const Eigen::Vector3d du_dq(pinhole.fx * iz, 0.0, -pinhole.fx * q.x() * iz * iz);
    const Eigen::Vector3d dv_dq(0.0, pinhole.fy * iz, -pinhole.fy * q.y() * iz * iz);
    const Eigen::Matrix<double, 1, 6> ju = leftJacobian(q, du_dq), jv = leftJacobian(q, dv_dq);
    H.noalias() += w * (ju.transpose() * ju + jv.transpose() * jv);
    if (bf > 0.0 && o.depth_m > 0.0) {  // u_right = u - bf / z
      const Eigen::Matrix<double, 1, 6> jr = leftJacobian(q, du_dq + Eigen::Vector3d(0.0, 0.0, bf * iz * iz));
      H.noalias() += w * jr.transpose() * jr;
    }
  }
  return H;
}

PoseCovariance poseCovariance(const std::vector<PoseObservation>& inliers, const Pinhole& pinhole,
                              const Eigen::Isometry3d& T_camera_world, const CameraRates& rates, double scale_factor,
                              double depth_baseline_m) {
  PoseCovariance out;
  const double bf = depth_baseline_m * pinhole.fx;
  double chi2 = 0.0;
  int residuals = 0, points = 0;
  for (const PoseObservation& o : inliers) {
    const Eigen::Vector3d p_c = pointAtRowTime(rates, o.row_time_s, T_camera_world * o.p_world_m);
    if (p_c.z() < 1e-3) continue;  // as featurePoseInformation
    const double sigma_px = std::pow(scale_factor, std::max(0, o.level));
    chi2 += whitenedChi2(o, p_c, pinhole, Eigen::Matrix2d::Identity() / sigma_px, sigma_px, bf);
    residuals += hasDepthResidual(o, bf) ? 3 : 2;
    ++points;
  }
  if (points < 3 || !std::isfinite(chi2)) return out;
  const PoseInformation H = featurePoseInformation(inliers, pinhole, T_camera_world, scale_factor, depth_baseline_m);
  const Eigen::SelfAdjointEigenSolver<PoseInformation> eigen(H);
  if (eigen.info() != Eigen::Success || !(eigen.eigenvalues()(0) > 1e-9 * eigen.eigenvalues()(5))) return out;
  out.variance_factor = residuals > 6 ? std::max(1.0, chi2 / (residuals - 6)) : 1.0;
  // Covariance of the left perturbation d = (v, w) of T_camera_world, in the camera frame.
  const PoseInformation covariance_camera = out.variance_factor * eigen.eigenvectors() *
                                            eigen.eigenvalues().cwiseInverse().asDiagonal() *
                                            eigen.eigenvectors().transpose();
  // T_world_camera' = T_world_camera (I - [w]x, -v) to first order: the centre moves by
  // -R_world_camera v and the camera turns by -R_world_camera w about the world axes.
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Zero();
  const Eigen::Matrix3d R_world_camera = T_camera_world.rotation().transpose();
  J.topLeftCorner<3, 3>() = -R_world_camera;
  J.bottomRightCorner<3, 3>() = -R_world_camera;
  out.world = J * covariance_camera * J.transpose();
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
