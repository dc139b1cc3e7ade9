#include "dypho/tracking/reprojection_error.h"

#include <cmath>
#include <utility>

#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>

#include "dypho/tracking/rolling_shutter_error.h"

namespace dypho {
namespace tracking {
namespace {

/// [a]x, the cross-product matrix of a.
Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

/// d (R(q) P) / d q for the 4 ambient quaternion coordinates [x, y, z, w] (see header):
/// f(q) = P + 2 w (v x P) + 2 v x (v x P), v x (v x P) = v (v.P) - P (v.v)
/// d f / d v = -2 w [P]x + 2 ((v.P) I + v P^T - 2 P v^T);  d f / d w = 2 (v x P).
Eigen::Matrix<double, 3, 4> rotationJacobian(const double* q, const Eigen::Vector3d& P) {
  const Eigen::Vector3d v(q[0], q[1], q[2]);
  const double w = q[3];
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() =
      -2.0 * w * skew(P) + 2.0 * (v.dot(P) * Eigen::Matrix3d::Identity() + v * P.transpose() - 2.0 * P * v.transpose());
  J.col(3) = 2.0 * v.cross(P);
  return J;
}

/// d (R(q) P) / d P: the rotation matrix of the unit quaternion q = [x, y, z, w],
/// R = I + 2 w [v]x + 2 [v]x^2.
Eigen::Matrix3d rotationMatrix(const double* q) {
  const Eigen::Matrix3d skew_v = skew(Eigen::Vector3d(q[0], q[1], q[2]));
  return Eigen::Matrix3d::Identity() + 2.0 * q[3] * skew_v + 2.0 * skew_v * skew_v;
}

/// Whitened pixel residual W (u - u_obs, v - v_obs) of the camera point p_c (the caller checks
/// p_c.z() > 0) written to residuals[0..1], W the 2x2 square-root information (I / sigma for a
/// keypoint without blur); returns d r / d p_c (2x3, whitened).
Eigen::Matrix<double, 2, 3> pixelResidual(const Pinhole& pinhole, const Eigen::Vector2d& uv_px,
                                          const Eigen::Matrix2d& sqrt_information, const Eigen::Vector3d& p_c,
                                          double* residuals) {
  const double inv_z = 1.0 / p_c.z();
  const double x = p_c.x() * inv_z, y = p_c.y() * inv_z;
  const Eigen::Vector2d e(pinhole.fx * x + pinhole.cx - uv_px.x(), pinhole.fy * y + pinhole.cy - uv_px.y());
  const Eigen::Vector2d r = sqrt_information * e;
  residuals[0] = r.x();
  residuals[1] = r.y();
  Eigen::Matrix<double, 2, 3> d_e_d_pc;
  d_e_d_pc << pinhole.fx * inv_z, 0.0, -pinhole.fx * x * inv_z,  //
      0.0, pinhole.fy * inv_z, -pinhole.fy * y * inv_z;
  return sqrt_information * d_e_d_pc;
}

/// The isotropic square-root information of a keypoint with 1 / sigma = inv_sigma.
Eigen::Matrix2d isotropic(double inv_sigma) { return Eigen::Matrix2d::Identity() * inv_sigma; }

/// newBaRelativePoseError's residual (header) for Ceres's automatic derivatives.
struct BaRelativePoseResidual {
  Eigen::Quaterniond q_meas_inv;
  Eigen::Vector3d t_meas;
  double w_rot;
  double w_trans;

  template <typename T>
  bool operator()(const T* q_a_raw, const T* t_a_raw, const T* q_b_raw, const T* t_b_raw, T* residuals) const {
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_raw), q_b(q_b_raw);
    const Eigen::Map<const Vector3> t_a(t_a_raw), t_b(t_b_raw);
    // X_a X_b^-1 = (R_a R_b^T, t_a - R_a R_b^T t_b).
    const Eigen::Quaternion<T> q_ab = q_a * q_b.conjugate();
    const Vector3 t_ab = t_a - q_ab * t_b;
    Eigen::Quaternion<T> q_error = q_meas_inv.cast<T>() * q_ab;
    if (q_error.w() < T(0)) q_error.coeffs() = -q_error.coeffs();
    const Vector3 rotation = T(2.0 * w_rot) * q_error.vec();
    const Vector3 translation = T(w_trans) * (q_meas_inv.cast<T>() * (t_ab - t_meas.cast<T>()));
    for (int i = 0; i < 3; ++i) {
      residuals[i] = rotation[i];
      residuals[3 + i] = translation[i];
    }
    return true;
  }
};

}  // namespace

ceres::CostFunction* newBaRelativePoseError(const Eigen::Isometry3d& T_a_b, double sigma_rot_rad,
                                            double sigma_trans_m) {
  const Eigen::Quaterniond q_meas = Eigen::Quaterniond(T_a_b.rotation()).normalized();
  auto* residual =
      new BaRelativePoseResidual{q_meas.conjugate(), T_a_b.translation(), 1.0 / sigma_rot_rad, 1.0 / sigma_trans_m};
  return new ceres::AutoDiffCostFunction<BaRelativePoseResidual, 6, 4, 3, 4, 3>(residual);
}

void angleAxisRotation(const Eigen::Vector3d& a, Eigen::Matrix3d* R, Eigen::Matrix3d* J_l) {
  const double t2 = a.squaredNorm();
  const Eigen::Matrix3d A = skew(a);
  const Eigen::Matrix3d A2 = A * A;
  double s1, s2, s3;  // sin t / t, (1 - cos t) / t^2, (t - sin t) / t^3
  if (t2 < 1e-8) {
    s1 = 1.0 - t2 / 6.0;
    s2 = 0.5 - t2 / 24.0;
    s3 = 1.0 / 6.0 - t2 / 120.0;
  } else {
    const double t = std::sqrt(t2);
    s1 = std::sin(t) / t;
    s2 = (1.0 - std::cos(t)) / t2;
    s3 = (t - std::sin(t)) / (t2 * t);
  }
  *R = Eigen::Matrix3d::Identity() + s1 * A + s2 * A2;
  if (J_l != nullptr) *J_l = Eigen::Matrix3d::Identity() + s2 * A + s3 * A2;
}

Eigen::Matrix<double, 3, 4> quaternionRotationJacobian(const double* q, const Eigen::Vector3d& P) {
  return rotationJacobian(q, P);
}

bool BaRgbdError::raw(double const* const* parameters, Eigen::Vector3d* r, Eigen::Matrix3d* d_r_d_pc) const {
  const double* q = parameters[0];
  const double* t = parameters[1];
  const Eigen::Vector3d P(parameters[2][0], parameters[2][1], parameters[2][2]);
  const Eigen::Vector3d p_c = ReprojectionError::rotate(q, P) + Eigen::Vector3d(t[0], t[1], t[2]);
  if (!(p_c.z() > 1e-6)) return false;
  const double inv_z = 1.0 / p_c.z();
  const Eigen::Matrix<double, 2, 3> d_px = pixelResidual(pinhole_, uv_px_, sqrt_information_, p_c, r->data());
  // Disparity b f (1/z - 1/z_meas) / sigma, d / d p_c = [0, 0, -b f / z^2] / sigma; all 0 without
  // a depth term (bf_ = 0).
  (*r)[2] = bf_ * (inv_z - inv_depth_) * inv_sigma_;
  if (d_r_d_pc != nullptr) {
    d_r_d_pc->topRows<2>() = d_px;
    d_r_d_pc->row(2) << 0.0, 0.0, -bf_ * inv_z * inv_z * inv_sigma_;
  }
  return true;
}

bool BaRgbdError::rawResiduals(double const* const* parameters, double* residuals) const {
  Eigen::Vector3d r;
  if (!raw(parameters, &r, nullptr)) return false;
  residuals[0] = r[0];
  residuals[1] = r[1];
  residuals[2] = r[2];
  return true;
}

namespace {

/// The Huber scale f(s) = sqrt(rho(s) / s) of a part with squared norm s and its derivative
/// d f / d s; (1, 0) inside the width. rho(s) = 2 h sqrt(s) - h^2 outside, so
/// f^2 = 2 h s^-1/2 - h^2 s^-1 and d f / d s = (-h s^-3/2 + h^2 s^-2) / (2 f).
std::pair<double, double> huberScale(double s, double huber) {
  if (huber <= 0.0 || s <= huber * huber) return {1.0, 0.0};
  const double root = std::sqrt(s);
  const double f = std::sqrt(2.0 * huber / root - huber * huber / s);
  return {f, (-huber / (s * root) + huber * huber / (s * s)) / (2.0 * f)};
}

}  // namespace

bool BaRgbdError::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  Eigen::Vector3d r;
  Eigen::Matrix3d d_r_d_pc;
  if (!raw(parameters, &r, jacobians != nullptr ? &d_r_d_pc : nullptr)) return false;
  // Each part scaled by its Huber factor; its Jacobian by the product rule:
  // d (f(s) r) = f dr + r f'(s) 2 r^T dr.
  const auto [f_px, df_px] = huberScale(r.head<2>().squaredNorm(), huber_);
  const auto [f_d, df_d] = huberScale(r[2] * r[2], huber_);
  residuals[0] = f_px * r[0];
  residuals[1] = f_px * r[1];
  residuals[2] = f_d * r[2];
  if (jacobians == nullptr) return true;
  Eigen::Matrix3d d_scaled;
  d_scaled.topRows<2>() = (f_px * Eigen::Matrix2d::Identity() + 2.0 * df_px * r.head<2>() * r.head<2>().transpose()) *
                          d_r_d_pc.topRows<2>();
  d_scaled.row(2) = (f_d + 2.0 * df_d * r[2] * r[2]) * d_r_d_pc.row(2);
  const double* q = parameters[0];
  const Eigen::Vector3d P(parameters[2][0], parameters[2][1], parameters[2][2]);
  using Jacobian34 = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;
  using Jacobian33 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  if (jacobians[0] != nullptr) {
    Eigen::Map<Jacobian34> J_q(jacobians[0]);
    J_q = d_scaled * rotationJacobian(q, P);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Jacobian33> J_t(jacobians[1]);
    J_t = d_scaled;
  }
  if (jacobians[2] != nullptr) {
    Eigen::Map<Jacobian33> J_p(jacobians[2]);
    J_p = d_scaled * rotationMatrix(q);
  }
  return true;
}

Eigen::Vector3d ReprojectionError::rotate(const double* q, const Eigen::Vector3d& p) {
  const Eigen::Vector3d v(q[0], q[1], q[2]);
  const double w = q[3];
  const Eigen::Vector3d vxp = v.cross(p);
  return p + 2.0 * w * vxp + 2.0 * v.cross(vxp);
}

bool ReprojectionError::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* q = parameters[0];
  const double* t = parameters[1];
  const Eigen::Vector3d p_c = rotate(q, p_world_m_) + Eigen::Vector3d(t[0], t[1], t[2]);
  if (!(p_c.z() > 1e-6)) return false;
  const Eigen::Matrix<double, 2, 3> d_r_d_pc = pixelResidual(pinhole_, uv_px_, sqrt_information_, p_c, residuals);
  if (jacobians == nullptr) return true;

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

bool RgbdReprojectionError::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* q = parameters[0];
  const double* t = parameters[1];
  const Eigen::Vector3d p_c = ReprojectionError::rotate(q, p_world_m_) + Eigen::Vector3d(t[0], t[1], t[2]);
  if (!(p_c.z() > 1e-6)) return false;
  const double inv_z = 1.0 / p_c.z();
  Eigen::Matrix<double, 3, 3> d_r_d_pc;
  d_r_d_pc.topRows<2>() = pixelResidual(pinhole_, uv_px_, isotropic(inv_sigma_), p_c, residuals);
  // Third row: the virtual right-camera column u - bf / z against the observed u_right.
  const double u = pinhole_.fx * p_c.x() * inv_z + pinhole_.cx;
  residuals[2] = (u - bf_ * inv_z - u_right_px_) * inv_sigma_;
  if (jacobians == nullptr) return true;
  d_r_d_pc.row(2) = d_r_d_pc.row(0);
  d_r_d_pc(2, 2) += bf_ * inv_z * inv_z * inv_sigma_;
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

bool RollingShutterReprojectionError::Evaluate(double const* const* parameters, double* residuals,
                                               double** jacobians) const {
  const double* q = parameters[0];
  const Eigen::Map<const Eigen::Vector3d> t(parameters[1]);
  const Eigen::Map<const Eigen::Vector3d> omega(parameters[2]);
  const Eigen::Map<const Eigen::Vector3d> velocity(parameters[3]);
  const double tau = row_time_s_;
  const Eigen::Vector3d p_stamp = ReprojectionError::rotate(q, p_world_m_) + t;
  // p_row = R(a) (p_stamp - v tau), a = -omega tau (pointAtRowTime).
  Eigen::Matrix3d R_a, J_l;
  angleAxisRotation(-tau * omega, &R_a, &J_l);
  const Eigen::Vector3d p_row = R_a * (p_stamp - tau * velocity);
  if (!(p_row.z() > 1e-6)) return false;
  const double inv_z = 1.0 / p_row.z();
  Eigen::Matrix<double, 3, 3> d_r_d_prow;
  d_r_d_prow.topRows<2>() = pixelResidual(pinhole_, uv_px_, sqrt_information_, p_row, residuals);
  // Third row: the virtual right column u - bf / z against the observed u_right (0 without depth).
  const double u = pinhole_.fx * p_row.x() * inv_z + pinhole_.cx;
  residuals[2] = bf_ > 0.0 ? (u - bf_ * inv_z - u_right_px_) * inv_sigma_ : 0.0;
  if (jacobians == nullptr) return true;
  if (bf_ > 0.0) {
    d_r_d_prow.row(2) << pinhole_.fx * inv_z * inv_sigma_, 0.0,
        (bf_ - pinhole_.fx * p_row.x()) * inv_z * inv_z * inv_sigma_;
  } else {
    d_r_d_prow.row(2).setZero();
  }
  const Eigen::Matrix3d d_r_d_stamp = d_r_d_prow * R_a;
  using Jacobian34 = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;
  using Jacobian33 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  if (jacobians[0] != nullptr) {
    Eigen::Map<Jacobian34> J_q(jacobians[0]);
    J_q = d_r_d_stamp * rotationJacobian(q, p_world_m_);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Jacobian33> J_t(jacobians[1]);
    J_t = d_r_d_stamp;
  }
  if (jacobians[2] != nullptr) {
    // d p_row / d omega = d p_row / d a * (-tau) = tau [p_row]x J_l(a).
    Eigen::Map<Jacobian33> J_omega(jacobians[2]);
    J_omega = d_r_d_prow * (tau * skew(p_row) * J_l);
  }
  if (jacobians[3] != nullptr) {
    Eigen::Map<Jacobian33> J_v(jacobians[3]);
    J_v = -tau * d_r_d_stamp;
  }
  return true;
}

}  // namespace tracking
}  // namespace dypho
