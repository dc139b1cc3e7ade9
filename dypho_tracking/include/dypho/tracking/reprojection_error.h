#pragma once
/// \file reprojection_error.h
/// Ceres reprojection residual with an analytic Jacobian for motion-only pose refinement.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/cost_function.h>
#include <ceres/sized_cost_function.h>

#include "dypho/tracking/pinhole.h"

namespace dypho {
namespace tracking {

/// Residual r = (pi(R(q) P_world + t) - uv_obs) / sigma, 2 x 1, whitened by the keypoint's scale
/// sigma = scale_factor^level (information 1/sigma^2, paper eq. "Pose Optimization"); or
/// r = W (pi(...) - uv_obs) with a 2x2 square-root information W (a blurred keypoint,
/// motion_blur.h).
///
/// Parameters (pose T_camera_world, i.e. world -> camera):
///  - block 0: quaternion q = [x, y, z, w] (Eigen storage order; use ceres::EigenQuaternionManifold);
///  - block 1: translation t [m].
/// The rotation is evaluated as R(q) P = P + 2 w (v x P) + 2 v x (v x P) with v = (x, y, z), exact
/// for unit q; the analytic Jacobian is the derivative of exactly this expression with respect
/// to the 4 ambient quaternion coordinates, and Ceres maps it to the 3-dof tangent space through the
/// manifold. Points with z <= 1e-6 m make Evaluate return false (Ceres then rejects the step).
class ReprojectionError final : public ceres::SizedCostFunction<2, 4, 3> {
 public:
  /// p_world_m: 3D point [m]; uv_px: observed undistorted pixel [px]; sigma_px: keypoint
  /// standard deviation [px] (> 0).
  ReprojectionError(const Eigen::Vector3d& p_world_m, const Eigen::Vector2d& uv_px, double sigma_px,
                    const Pinhole& pinhole)
      : p_world_m_(p_world_m),
        uv_px_(uv_px),
        sqrt_information_(Eigen::Matrix2d::Identity() / sigma_px),
        pinhole_(pinhole) {}
  /// sqrt_information_px: W [1/px], symmetric positive definite.
  ReprojectionError(const Eigen::Vector3d& p_world_m, const Eigen::Vector2d& uv_px,
                    const Eigen::Matrix2d& sqrt_information_px, const Pinhole& pinhole)
      : p_world_m_(p_world_m), uv_px_(uv_px), sqrt_information_(sqrt_information_px), pinhole_(pinhole) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  /// Rotates p by the (possibly not exactly unit) quaternion q = [x, y, z, w] with the formula above.
  static Eigen::Vector3d rotate(const double* q, const Eigen::Vector3d& p);

 private:
  Eigen::Vector3d p_world_m_;
  Eigen::Vector2d uv_px_;
  Eigen::Matrix2d sqrt_information_;
  Pinhole pinhole_;
};

/// RGB-D variant with a third, depth residual in the style of ORB-SLAM's RGB-D tracking: the depth
/// measured in the current frame is turned into the column of a virtual right camera,
/// u_r = u - b f_x / z, so r = ([u, v, u - b f_x / z]_predicted - [u, v, u - b f_x / z_measured]) / sigma.
/// In disparity units the Kinect-like depth noise is roughly constant, so one sigma fits all three
/// components. Same parameter blocks and Jacobian conventions as ReprojectionError.
class RgbdReprojectionError final : public ceres::SizedCostFunction<3, 4, 3> {
 public:
  /// depth_m: depth measured at the observation in the current frame [m] (> 0);
  /// baseline_m: virtual stereo baseline b [m] (> 0).
  RgbdReprojectionError(const Eigen::Vector3d& p_world_m, const Eigen::Vector2d& uv_px, double depth_m,
                        double baseline_m, double sigma_px, const Pinhole& pinhole)
      : p_world_m_(p_world_m),
        uv_px_(uv_px),
        u_right_px_(uv_px.x() - baseline_m * pinhole.fx / depth_m),
        bf_(baseline_m * pinhole.fx),
        inv_sigma_(1.0 / sigma_px),
        pinhole_(pinhole) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d p_world_m_;
  Eigen::Vector2d uv_px_;
  double u_right_px_;
  double bf_;
  double inv_sigma_;
  Pinhole pinhole_;
};

/// Bundle-adjustment variant of ReprojectionError: the 3D point is a parameter too.
/// One observation of bundle adjustment for RGB-D keyframes, as one residual block of three rows:
/// the whitened pixel residual r_px = W (u - u_obs, v - v_obs) (conventions as
/// ReprojectionError) and the depth term in disparity units (ORB-SLAM's virtual stereo column)
/// r_d = b f_x (1 / z_pred - 1 / z_measured) / sigma, z_pred = (R(q) P + t)_z, which fixes the
/// metric scale that reprojection alone leaves free when few keyframes are fixed. Without a
/// measured depth (or with b f_x = 0) r_d is 0 with a zero Jacobian.
///
/// Each part carries its own Huber loss (width huber_px), inside the block: the rows are
/// [sqrt(rho(|r_px|^2) / |r_px|^2) r_px; sqrt(rho(r_d^2) / r_d^2) r_d], rho(s) = s for
/// s <= huber^2, else 2 huber sqrt(s) - huber^2, so the block's squared norm is
/// rho(|r_px|^2) + rho(r_d^2): the cost of a pixel block and a depth block with a Huber loss each,
/// in half the blocks. Add it without a Ceres loss. The Jacobians are those of these rows (the
/// scale is continuous with a continuous derivative at the Huber width). rawResiduals() gives
/// r_px and r_d before the loss (for chi2 tests).
///
/// Parameters: block 0 quaternion of T_camera_world [x, y, z, w], block 1 translation of
/// T_camera_world [m], block 2 point in the world [m]; d r / d P = d r / d p_c * M(q),
/// M(q) = I + 2 w [v]x + 2 [v]x^2 (the exact linear map of the rotation formula, also for
/// non-unit q). Every block has three rows, point blocks of 3 and pose blocks of 3 (tangent), so
/// Ceres's Schur elimination uses its fixed-size 3x3x3 kernel.
class BaRgbdError final : public ceres::SizedCostFunction<3, 4, 3, 3> {
 public:
  /// uv_px: observed undistorted pixel [px]; sqrt_information: 2x2 square-root information of
  /// the pixel [1/px] (I / sigma_px for a sharp keypoint; motion_blur.h for a blurred one);
  /// depth_m: measured depth [m], <= 0 for none; bf_px_m: baseline [m] times f_x [px], 0 for no
  /// depth term; sigma_px (> 0): the depth term's standard deviation in disparity [px];
  /// huber: the Huber width of each part in whitened units (> 0), 0 for none (plain squares).
  BaRgbdError(const Eigen::Vector2d& uv_px, const Eigen::Matrix2d& sqrt_information, const Pinhole& pinhole,
              double depth_m, double bf_px_m, double sigma_px, double huber)
      : uv_px_(uv_px),
        sqrt_information_(sqrt_information),
        pinhole_(pinhole),
        inv_depth_(depth_m > 0.0 ? 1.0 / depth_m : 0.0),
        bf_(depth_m > 0.0 ? bf_px_m : 0.0),
        inv_sigma_(1.0 / sigma_px),
        huber_(huber) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  /// r_px (rows 0-1) and r_d (row 2) before the Huber loss; false behind the camera.
  bool rawResiduals(double const* const* parameters, double* residuals) const;

  /// True when the block has a depth term (a measured depth and b f_x > 0).
  bool hasDepth() const { return bf_ > 0.0; }

 private:
  /// The raw rows and d r / d p_c (3x3; nullptr: not needed).
  bool raw(double const* const* parameters, Eigen::Vector3d* r, Eigen::Matrix3d* d_r_d_pc) const;

  Eigen::Vector2d uv_px_;
  Eigen::Matrix2d sqrt_information_;
  Pinhole pinhole_;
  double inv_depth_;
  double bf_;  ///< 0: no depth term
  double inv_sigma_;
  double huber_;  ///< 0: no loss
};

/// Prior on the relative pose of two keyframes in bundle adjustment: with the BA's pose blocks
/// X = T_camera_world, T_a_b = X_a X_b^-1 (keyframe b in keyframe a) against a measured T_a_b,
/// r = [2 vec(q_meas^-1 (x) q_ab) / sigma_rot_rad; R_meas^T (t_ab - t_meas) / sigma_trans_m]
/// (6 x 1, the quaternion error taken in the hemisphere of w >= 0). Parameter blocks: q_a
/// [x, y, z, w], t_a [m], q_b, t_b (EigenQuaternionManifold on the quaternions). Automatic
/// derivatives: a problem has one per keyframe pair, against thousands of reprojection residuals.
/// sigma_rot_rad, sigma_trans_m > 0. The caller owns the result until Ceres takes it.
ceres::CostFunction* newBaRelativePoseError(const Eigen::Isometry3d& T_a_b, double sigma_rot_rad, double sigma_trans_m);

/// d (R(q) P) / d q for the 4 ambient quaternion coordinates [x, y, z, w] of the rotation formula
/// of ReprojectionError::rotate (3 x 4).
Eigen::Matrix<double, 3, 4> quaternionRotationJacobian(const double* q, const Eigen::Vector3d& P);

}  // namespace tracking
}  // namespace dypho
