#include "dypho/tracking/reprojection_error.h"

#include <Eigen/Geometry>

namespace dypho {
namespace tracking {
namespace {

/// d (R(q) P) / d q for the 4 ambient quaternion coordinates [x, y, z, w] (see header):
/// f(q) = P + 2 w (v x P) + 2 v x (v x P), v x (v x P) = v (v.P) - P (v.v)
/// d f / d v = -2 w [P]x + 2 ((v.P) I + v P^T - 2 P v^T);  d f / d w = 2 (v x P).
Eigen::Matrix<double, 3, 4> rotationJacobian(const double* q, const Eigen::Vector3d& P) {
  const Eigen::Vector3d v(q[0], q[1], q[2]);
  const double w = q[3];
  Eigen::Matrix3d skew_p;
  skew_p << 0, -P.z(), P.y(), P.z(), 0, -P.x(), -P.y(), P.x(), 0;
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() = -2.0 * w * skew_p +
                    2.0 * (v.dot(P) * Eigen::Matrix3d::Identity() + v * P.transpose() -
                           2.0 * P * v.transpose());
  J.col(3) = 2.0 * v.cross(P);
  return J;
}

}  // namespace

Eigen::Matrix<double, 3, 4> quaternionRotationJacobian(const double* q, const Eigen::Vector3d& P) {
  return rotationJacobian(q, P);
}

bool BaReprojectionError::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  const double* q = parameters[0];
  const double* t = parameters[1];
  const Eigen::Vector3d P(parameters[2][0], parameters[2][1], parameters[2][2]);
  const Eigen::Vector3d p_c = ReprojectionError::rotate(q, P) + Eigen::Vector3d(t[0], t[1], t[2]);
  if (!(p_c.z() > 1e-6)) return false;
  const double inv_z = 1.0 / p_c.z();
  const double x = p_c.x() * inv_z, y = p_c.y() * inv_z;
  residuals[0] = (pinhole_.fx * x + pinhole_.cx - uv_px_.x()) * inv_sigma_;
  residuals[1] = (pinhole_.fy * y + pinhole_.cy - uv_px_.y()) * inv_sigma_;
  if (jacobians == nullptr) return true;
  Eigen::Matrix<double, 2, 3> d_r_d_pc;
  d_r_d_pc << pinhole_.fx * inv_z, 0.0, -pinhole_.fx * x * inv_z,  //
      0.0, pinhole_.fy * inv_z, -pinhole_.fy * y * inv_z;
  d_r_d_pc *= inv_sigma_;
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 4, Eigen::RowMajor>> J_q(jacobians[0]);
    J_q = d_r_d_pc * rotationJacobian(q, P);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J_t(jacobians[1]);
    J_t = d_r_d_pc;
  }
  if (jacobians[2] != nullptr) {
    const Eigen::Vector3d v(q[0], q[1], q[2]);
    Eigen::Matrix3d skew_v;
    skew_v << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    const Eigen::Matrix3d M = Eigen::Matrix3d::Identity() + 2.0 * q[3] * skew_v + 2.0 * skew_v * skew_v;
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J_p(jacobians[2]);
    J_p = d_r_d_pc * M;
  }
  return true;
}

bool BaDepthError::Evaluate(double const* const* parameters, double* residuals,
                            double** jacobians) const {
  const double* q = parameters[0];
  const double* t = parameters[1];
  const Eigen::Vector3d P(parameters[2][0], parameters[2][1], parameters[2][2]);
  const Eigen::Vector3d p_c = ReprojectionError::rotate(q, P) + Eigen::Vector3d(t[0], t[1], t[2]);
  if (!(p_c.z() > 1e-6)) return false;
  const double inv_z = 1.0 / p_c.z();
  residuals[0] = bf_ * (inv_z - inv_depth_) * inv_sigma_;
  if (jacobians == nullptr) return true;
  // d r / d p_c = [0, 0, -bf / z^2] / sigma.
  const Eigen::RowVector3d d_r_d_pc(0.0, 0.0, -bf_ * inv_z * inv_z * inv_sigma_);
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 1, 4>> J_q(jacobians[0]);
    J_q = d_r_d_pc * rotationJacobian(q, P);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 1, 3>> J_t(jacobians[1]);
    J_t = d_r_d_pc;
  }
  if (jacobians[2] != nullptr) {
    const Eigen::Vector3d v(q[0], q[1], q[2]);
    Eigen::Matrix3d skew_v;
    skew_v << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    const Eigen::Matrix3d M = Eigen::Matrix3d::Identity() + 2.0 * q[3] * skew_v + 2.0 * skew_v * skew_v;
    Eigen::Map<Eigen::Matrix<double, 1, 3>> J_p(jacobians[2]);
    J_p = d_r_d_pc * M;
  }
  return true;
}

Eigen::Vector3d ReprojectionError::rotate(const double* q, const Eigen::Vector3d& p) {
  const Eigen::Vector3d v(q[0], q[1], q[2]);
  const double w = q[3];
  const Eigen::Vector3d vxp = v.cross(p);
  return p + 2.0 * w * vxp + 2.0 * v.cross(vxp);
}

bool ReprojectionError::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const double* q = parameters[0];
  const double* t = parameters[1];
  const Eigen::Vector3d p_c = rotate(q, p_world_m_) + Eigen::Vector3d(t[0], t[1], t[2]);
  if (!(p_c.z() > 1e-6)) return false;
  const double inv_z = 1.0 / p_c.z();
  const double x = p_c.x() * inv_z, y = p_c.y() * inv_z;
  residuals[0] = (pinhole_.fx * x + pinhole_.cx - uv_px_.x()) * inv_sigma_;
  residuals[1] = (pinhole_.fy * y + pinhole_.cy - uv_px_.y()) * inv_sigma_;
  if (jacobians == nullptr) return true;

  // d r / d p_c (whitened).
  Eigen::Matrix<double, 2, 3> d_r_d_pc;
  d_r_d_pc << pinhole_.fx * inv_z, 0.0, -pinhole_.fx * x * inv_z,  //
      0.0, pinhole_.fy * inv_z, -pinhole_.fy * y * inv_z;
  d_r_d_pc *= inv_sigma_;

  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 4, Eigen::RowMajor>> J_q(jacobians[0]);
    J_q = d_r_d_pc * rotationJacobian(q, p_world_m_);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J_t(jacobians[1]);
    J_t = d_r_d_pc;
  }
  return true;
}

bool RgbdReprojectionError::Evaluate(double const* const* parameters, double* residuals,
                                     double** jacobians) const {
  const double* q = parameters[0];
  const double* t = parameters[1];
  const Eigen::Vector3d p_c =
      ReprojectionError::rotate(q, p_world_m_) + Eigen::Vector3d(t[0], t[1], t[2]);
  if (!(p_c.z() > 1e-6)) return false;
  const double inv_z = 1.0 / p_c.z();
  const double x = p_c.x() * inv_z, y = p_c.y() * inv_z;
  const double u = pinhole_.fx * x + pinhole_.cx;
  residuals[0] = (u - uv_px_.x()) * inv_sigma_;
  residuals[1] = (pinhole_.fy * y + pinhole_.cy - uv_px_.y()) * inv_sigma_;
  residuals[2] = (u - bf_ * inv_z - u_right_px_) * inv_sigma_;
  if (jacobians == nullptr) return true;

  Eigen::Matrix<double, 3, 3> d_r_d_pc;
  d_r_d_pc << pinhole_.fx * inv_z, 0.0, -pinhole_.fx * x * inv_z,  //
      0.0, pinhole_.fy * inv_z, -pinhole_.fy * y * inv_z,          //
      pinhole_.fx * inv_z, 0.0, -pinhole_.fx * x * inv_z + bf_ * inv_z * inv_z;
  d_r_d_pc *= inv_sigma_;
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> J_q(jacobians[0]);
    J_q = d_r_d_pc * rotationJacobian(q, p_world_m_);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J_t(jacobians[1]);
    J_t = d_r_d_pc;
  }
  return true;
}

}  // namespace tracking
}  // namespace dypho
