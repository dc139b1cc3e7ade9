#pragma once
/// \file motion_blur.h
/// Keypoints of a motion-blurred image, weighted by their blur. While the shutter is open for
/// `exposure_s`, a point sweeps a streak along its image motion; a corner found on the streak
/// lies anywhere along it, while across it the position keeps the keypoint's own precision. The
/// pixel residual is therefore whitened by a 2x2 square-root information W with two axes: across
/// the streak 1 / sigma, along it 1 / sqrt(sigma^2 + (L / sqrt(12))^2), L the streak's length
/// [px] (1 / sqrt(12): the standard deviation of a position uniform over a unit length). With no
/// motion W = I / sigma, the isotropic weight of the keypoint's level.
///
/// The streak is the image velocity of the point under the camera's velocities during the frame
/// (CameraRates, in its optical frame at the stamp: a point p moves as dp/dt = -omega x p - v)
/// times the exposure. The motion-only refinement and its inlier test both use this one
/// function, so an observation weighted here is judged with the same weight.

#include <cmath>

#include <Eigen/Core>

#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/rolling_shutter_error.h"

namespace dypho {
namespace tracking {

/// Image velocity of the camera point p_camera_m under `rates` [px/s]; zero for a point at or
/// behind the camera (z <= 1e-6 m).
inline Eigen::Vector2d imageVelocityPxS(const Eigen::Vector3d& p_camera_m, const CameraRates& rates,
                                        const Pinhole& pinhole) {
  const double z = p_camera_m.z();
  if (!(z > 1e-6)) return Eigen::Vector2d::Zero();
  const Eigen::Vector3d p_dot = -rates.omega_rad_s.cross(p_camera_m) - rates.velocity_m_s;
  return Eigen::Vector2d(pinhole.fx * (p_dot.x() * z - p_camera_m.x() * p_dot.z()) / (z * z),
                         pinhole.fy * (p_dot.y() * z - p_camera_m.y() * p_dot.z()) / (z * z));
}

/// Square-root information W (2x2, symmetric) of a keypoint with standard deviation sigma_px
/// [px] (> 0) blurred along `streak_px`, its image motion over the exposure [px] (file comment).
/// A zero or non-finite streak: I / sigma_px.
inline Eigen::Matrix2d streakSqrtInformation(const Eigen::Vector2d& streak_px, double sigma_px) {
  const Eigen::Matrix2d isotropic = Eigen::Matrix2d::Identity() / sigma_px;
  const double length_px = streak_px.norm();
  if (!std::isfinite(length_px) || !(length_px > 1e-9)) return isotropic;
  const Eigen::Vector2d along = streak_px / length_px;
  const Eigen::Vector2d across(-along.y(), along.x());
  const double sigma_along_px = std::sqrt(sigma_px * sigma_px + length_px * length_px / 12.0);
  return across * across.transpose() / sigma_px + along * along.transpose() / sigma_along_px;
}

/// The same W of a keypoint whose point, at p_camera_m, is blurred over exposure_s [s] by
/// `rates`. exposure_s <= 0, no motion or a non-finite streak: I / sigma_px.
inline Eigen::Matrix2d blurSqrtInformation(const Eigen::Vector3d& p_camera_m, const CameraRates& rates,
                                           const Pinhole& pinhole, double exposure_s, double sigma_px) {
  if (!(exposure_s > 0.0)) return Eigen::Matrix2d::Identity() / sigma_px;
  return streakSqrtInformation(imageVelocityPxS(p_camera_m, rates, pinhole) * exposure_s, sigma_px);
}

}  // namespace tracking
}  // namespace dypho
