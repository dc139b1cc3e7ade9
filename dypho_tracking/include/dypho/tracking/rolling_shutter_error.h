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
#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "dypho/tracking/pinhole.h"

namespace dypho {
namespace tracking {

/// The camera's motion during one frame, in its optical frame at the stamp.
struct CameraRates {
  Eigen::Vector3d omega_rad_s = Eigen::Vector3d::Zero();   ///< angular velocity [rad/s]
  Eigen::Vector3d velocity_m_s = Eigen::Vector3d::Zero();  ///< linear velocity [m/s]
};

/// p_row = exp(-omega tau) (p_stamp - v tau), tau = row_time_s (see the file comment); T = double
/// or a Ceres Jet.
template <typename T>
void pointAtRowTime(const T* omega_rad_s, const T* velocity_m_s, double row_time_s, const T* p_stamp, T* p_row) {
  const T angle_axis[3] = {-omega_rad_s[0] * row_time_s, -omega_rad_s[1] * row_time_s, -omega_rad_s[2] * row_time_s};
  const T moved[3] = {p_stamp[0] - velocity_m_s[0] * row_time_s, p_stamp[1] - velocity_m_s[1] * row_time_s,
                      p_stamp[2] - velocity_m_s[2] * row_time_s};
  ceres::AngleAxisRotatePoint(angle_axis, moved, p_row);
}

/// pointAtRowTime for Eigen vectors.
inline Eigen::Vector3d pointAtRowTime(const CameraRates& rates, double row_time_s, const Eigen::Vector3d& p_stamp) {
  Eigen::Vector3d p_row;
  pointAtRowTime(rates.omega_rad_s.data(), rates.velocity_m_s.data(), row_time_s, p_stamp.data(), p_row.data());
  return p_row;
}

/// Residual of one observation seen at `row_time_s` from the stamp: the pixel error of the point
/// projected with its row's camera, whitened by the 2x2 square-root information W (I / sigma, or
/// a blurred keypoint's, motion_blur.h), and, when the observation has a depth, the virtual
/// right column's error as in RgbdReprojectionError (else 0). Parameters: the quaternion of
/// T_camera_world [x, y, z, w] (EigenQuaternionManifold), its translation [m], omega [rad/s], v
/// [m/s].
struct RollingShutterReprojectionError {
  /// sqrt_information_px: W [1/px]; sigma_px whitens the depth residual.
  RollingShutterReprojectionError(const Eigen::Vector3d& p_world_m, const Eigen::Vector2d& uv_px, double depth_m,
                                  double bf_px_m, double sigma_px, const Eigen::Matrix2d& sqrt_information_px,
                                  double row_time_s, const Pinhole& pinhole)
      : p_world_m(p_world_m),
        uv_px(uv_px),
        u_right_px(depth_m > 0.0 && bf_px_m > 0.0 ? uv_px.x() - bf_px_m / depth_m : 0.0),
        bf(depth_m > 0.0 ? bf_px_m : 0.0),
        inv_sigma(1.0 / sigma_px),
        sqrt_information(sqrt_information_px),
        row_time_s(row_time_s),
        pinhole(pinhole) {}

  template <typename T>
  bool operator()(const T* q_cw, const T* t_cw, const T* omega_rad_s, const T* velocity_m_s, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_cw);
    const Eigen::Matrix<T, 3, 1> p_stamp = q * p_world_m.cast<T>() + Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t_cw);
    T p_row[3];
    pointAtRowTime(omega_rad_s, velocity_m_s, row_time_s, p_stamp.data(), p_row);
    if (!(p_row[2] > T(1e-6))) return false;
    const T inv_z = T(1.0) / p_row[2];
    const T u = T(pinhole.fx) * p_row[0] * inv_z + T(pinhole.cx);
    const T e_u = u - T(uv_px.x());
    const T e_v = T(pinhole.fy) * p_row[1] * inv_z + T(pinhole.cy) - T(uv_px.y());
    residuals[0] = T(sqrt_information(0, 0)) * e_u + T(sqrt_information(0, 1)) * e_v;
    residuals[1] = T(sqrt_information(1, 0)) * e_u + T(sqrt_information(1, 1)) * e_v;
    residuals[2] = bf > 0.0 ? (u - T(bf) * inv_z - T(u_right_px)) * inv_sigma : T(0.0);
    return true;
  }

  /// The Ceres cost (3 residuals; parameter blocks 4, 3, 3, 3).
  static ceres::CostFunction* create(const Eigen::Vector3d& p_world_m, const Eigen::Vector2d& uv_px, double depth_m,
                                     double bf_px_m, double sigma_px, const Eigen::Matrix2d& sqrt_information_px,
                                     double row_time_s, const Pinhole& pinhole) {
    return new ceres::AutoDiffCostFunction<RollingShutterReprojectionError, 3, 4, 3, 3, 3>(
        new RollingShutterReprojectionError(p_world_m, uv_px, depth_m, bf_px_m, sigma_px, sqrt_information_px,
                                            row_time_s, pinhole));
  }

  Eigen::Vector3d p_world_m;
  Eigen::Vector2d uv_px;
  double u_right_px;
  double bf;
  double inv_sigma;
  Eigen::Matrix2d sqrt_information;
  double row_time_s;
  Pinhole pinhole;
};

/// Prior on a rate (the angular or the linear velocity) about `center` (the motion model's):
/// r = (rate - center) / sigma (3 residuals, one block of 3).
struct RatePrior {
  RatePrior(const Eigen::Vector3d& center, double sigma) : center(center), inv_sigma(1.0 / sigma) {}

  template <typename T>
  bool operator()(const T* rate, T* residuals) const {
    for (int i = 0; i < 3; ++i) residuals[i] = (rate[i] - T(center[i])) * inv_sigma;
    return true;
  }

  /// The Ceres cost.
  static ceres::CostFunction* create(const Eigen::Vector3d& center, double sigma) {
    return new ceres::AutoDiffCostFunction<RatePrior, 3, 3>(new RatePrior(center, sigma));
  }

  Eigen::Vector3d center;
  double inv_sigma;
};

}  // namespace tracking
}  // namespace dypho
