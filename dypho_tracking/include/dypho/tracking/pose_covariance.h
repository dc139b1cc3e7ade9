#pragma once
/// \file pose_covariance.h
/// How precisely a tracked frame's matches fix its pose: the covariance of the motion-only
/// estimate, in the world frame, for consumers that fuse poses (a robot's EKF) and for judging
/// frames whose static points cannot tell a sideways shift from a turn.

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/pose_optimizer.h"
#include "dypho/tracking/rolling_shutter_error.h"

namespace dypho {
namespace tracking {

/// Information matrix of a 6-dof pose on its left perturbation [v (m), w (rad)], T' = exp(d) T.
using PoseInformation = Eigen::Matrix<double, 6, 6>;

/// d r / d(v, w) of the left perturbation q' = q + v + w x q of a point q in the camera, given
/// d r / d q.
inline Eigen::Matrix<double, 1, 6> leftJacobian(const Eigen::Vector3d& q, const Eigen::Vector3d& dr_dq) {
  Eigen::Matrix<double, 1, 6> j;
  j.head<3>() = dr_dq.transpose();
  j.tail<3>() = q.cross(dr_dq).transpose();
  return j;
}

/// Information of the feature pose T_camera_world from its inlier observations, on the left
/// perturbation T' = exp(v, w) T_camera_world (which is also that of T_current_reference =
/// T_camera_world * T_world_reference): the Gauss-Newton information of the residuals `optimizer`
/// minimises for them at that pose (PoseOptimizer::costsAt: sigma = scale_factor^level [px], the
/// virtual right column when depth_baseline_m > 0 and the observation has a depth), sharp, and with
/// a rolling shutter's velocities held at zero (observations at the stamp: row time 0).
PoseInformation featurePoseInformation(const PoseOptimizer& optimizer, const std::vector<PoseObservation>& inliers,
                                       const Pinhole& pinhole, const Eigen::Isometry3d& T_camera_world);

/// Covariance of a camera pose, ordered as ROS's geometry_msgs/PoseWithCovariance: the camera
/// centre along the world axes x, y, z [m^2], then a small rotation of the camera about the world
/// axes x, y, z [rad^2], the rotation applied before the pose (R' = exp(phi) R_world_camera).
struct PoseCovariance {
  bool valid = false;  ///< false: too few points, or they leave a direction of the pose free
  Eigen::Matrix<double, 6, 6> world = Eigen::Matrix<double, 6, 6>::Zero();  ///< zero when invalid
  /// Mean squared whitened residual per degree of freedom, at least 1 (see poseCovariance) [-].
  double variance_factor = 1.0;

  /// The largest standard deviation of the camera centre, along any direction [m]; 0 when invalid.
  double maxPositionSigmaM() const;
};

/// The covariance of the pose T_camera_world that `optimizer` estimated from `inliers` (its
/// inlier observations), with `rates`, `blur_rates` and `exposure_s` from that estimate
/// (PoseOptimizerResult's rates, blur_rates and blur_exposure_s): the inverse of the
/// Gauss-Newton information of the residuals the solve minimised (PoseOptimizer::costsAt: each
/// keypoint whitened by its pyramid level's sigma and, on a fast turn, by its blur streak, plus
/// the depth residual when depth_baseline_m > 0), scaled by the variance factor, their squared
/// residuals per residual minus 6, at least 1: a pose is never reported more precise than the
/// keypoint noise model allows. With a rolling shutter the velocities were estimated with the
/// pose, under priors: they are marginalised out (a Schur complement), so what they leave
/// uncertain is in the pose's.
/// It is the precision relative to the points, which are taken as exact: the map's own error
/// (drift between keyframes) is not in it. Invalid with fewer than 3 points in front of the
/// camera or an information matrix whose smallest eigenvalue is below 1e-9 of its largest.
PoseCovariance poseCovariance(const PoseOptimizer& optimizer, const std::vector<PoseObservation>& inliers,
                              const Pinhole& pinhole, const Eigen::Isometry3d& T_camera_world, const CameraRates& rates,
                              const CameraRates& blur_rates, double exposure_s);

}  // namespace tracking
}  // namespace dypho
