#pragma once
/// \file rolling_shutter_error.h
/// Motion-only refinement with a rolling shutter: each image row is exposed at its own time, so a
/// point is projected with the camera of its keypoint's row. Within the frame the camera moves at
/// a constant angular velocity omega [rad/s] and linear velocity v [m/s], both in its optical
/// frame at the stamp: the camera of a row read out `row_time_s` = tau after the stamp is the
/// stamp's moved by (exp(omega tau), v tau), so it sees the point p_stamp (camera at the stamp) at
/// p_row = exp(-omega tau) (p_stamp - v tau), the inverse of compensateRollingShutter's motion.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/sized_cost_function.h>

#include "dypho/tracking/pinhole.h"

namespace dypho {
namespace tracking {

/// The camera's motion during one frame, in its optical frame at the stamp.
struct CameraRates {
  Eigen::Vector3d omega_rad_s = Eigen::Vector3d::Zero();   ///< angular velocity [rad/s]
  Eigen::Vector3d velocity_m_s = Eigen::Vector3d::Zero();  ///< linear velocity [m/s]
};

/// Rotation matrix R of the angle-axis vector a [rad] and, when J_l is given, the left Jacobian
/// of SO(3) at a, J_l(a) = I + (1 - cos t) / t^2 [a]x + (t - sin t) / t^3 [a]x^2 (t = |a|; a
/// series for t < 1e-4 rad): R(a + d) p = (I + [J_l(a) d]x) R(a) p to first order, so
/// d (R(a) p) / d a = -[R(a) p]x J_l(a).
void angleAxisRotation(const Eigen::Vector3d& a, Eigen::Matrix3d* R, Eigen::Matrix3d* J_l = nullptr);

/// p_row = exp(-omega tau) (p_stamp - v tau), tau = row_time_s (see the file comment).
inline Eigen::Vector3d pointAtRowTime(const CameraRates& rates, double row_time_s, const Eigen::Vector3d& p_stamp) {
  Eigen::Matrix3d R;
  angleAxisRotation(-row_time_s * rates.omega_rad_s, &R);
  return R * (p_stamp - row_time_s * rates.velocity_m_s);
}

/// Residual of one observation seen at `row_time_s` from the stamp: the pixel error of the point
/// projected with its row's camera, whitened by the 2x2 square-root information W (I / sigma, or
/// a blurred keypoint's, motion_blur.h), and, when the observation has a depth, the virtual
/// right column's error as in RgbdReprojectionError (else 0). Parameters: the quaternion of
/// T_camera_world [x, y, z, w] (EigenQuaternionManifold), its translation [m], omega [rad/s], v
/// [m/s]. Analytic Jacobian (reprojection_error.cpp), with d p_row / d omega = tau [p_row]x
/// J_l(-omega tau), J_l the left Jacobian of SO(3); Evaluate returns false for p_row.z <= 1e-6 m.
class RollingShutterReprojectionError final : public ceres::SizedCostFunction<3, 4, 3, 3, 3> {
 public:
  /// sqrt_information_px: W [1/px]; sigma_px whitens the depth residual; depth_m 0 or bf_px_m 0:
  /// no depth residual (the third residual is 0).
  RollingShutterReprojectionError(const Eigen::Vector3d& p_world_m, const Eigen::Vector2d& uv_px, double depth_m,
                                  double bf_px_m, double sigma_px, const Eigen::Matrix2d& sqrt_information_px,
                                  double row_time_s, const Pinhole& pinhole)
      : p_world_m_(p_world_m),
        uv_px_(uv_px),
        u_right_px_(depth_m > 0.0 && bf_px_m > 0.0 ? uv_px.x() - bf_px_m / depth_m : 0.0),
        bf_(depth_m > 0.0 ? bf_px_m : 0.0),
        inv_sigma_(1.0 / sigma_px),
        sqrt_information_(sqrt_information_px),
        row_time_s_(row_time_s),
        pinhole_(pinhole) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d p_world_m_;
  Eigen::Vector2d uv_px_;
  double u_right_px_;
  double bf_;
  double inv_sigma_;
  Eigen::Matrix2d sqrt_information_;
  double row_time_s_;
  Pinhole pinhole_;
};

/// Prior on a rate (the angular or the linear velocity) about `center` (the motion model's):
/// r = (rate - center) / sigma (3 residuals, one block of 3; Jacobian I / sigma).
class RatePrior final : public ceres::SizedCostFunction<3, 3> {
 public:
  RatePrior(const Eigen::Vector3d& center, double sigma) : center_(center), inv_sigma_(1.0 / sigma) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    for (int i = 0; i < 3; ++i) residuals[i] = (parameters[0][i] - center_[i]) * inv_sigma_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[0]);
      J = Eigen::Matrix3d::Identity() * inv_sigma_;
    }
    return true;
  }

 private:
  Eigen::Vector3d center_;
  double inv_sigma_;
};

}  // namespace tracking
}  // namespace dypho
