#pragma once
/// \file pose_optimizer.h
/// Motion-only bundle adjustment of one camera pose against fixed 3D points (Ceres).

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/rolling_shutter_error.h"
#include "dypho/tracking/tracking_options.h"

namespace ceres {
class CostFunction;
}  // namespace ceres

namespace dypho {
namespace tracking {

/// One 3D-2D correspondence.
struct PoseObservation {
  Eigen::Vector3d p_world_m = Eigen::Vector3d::Zero();  ///< fixed 3D point in the world [m]
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();      ///< observed undistorted pixel [px]
  int level = 0;  ///< pyramid level of the observation; sigma = scale_factor^level [px]
  /// Depth measured at the observation in the current frame [m]; > 0 adds the depth residual
  /// (RgbdReprojectionError) when depth_baseline_m > 0, 0 = reprojection only.
  double depth_m = 0.0;
  /// Time its image row was exposed, relative to the frame's stamp (rowTimeOffsetS) [s]; with
  /// rolling_shutter_readout_ms > 0 the point is projected with that row's camera. 0 = at the stamp.
  double row_time_s = 0.0;
};

/// True when `o` adds the depth residual u - bf / z (RgbdReprojectionError): a virtual stereo
/// bf = depth_baseline_m * fx > 0 [px m] and a measured depth.
inline bool hasDepthResidual(const PoseObservation& o, double bf) { return bf > 0.0 && o.depth_m > 0.0; }

/// Result of PoseOptimizer::optimize.
struct PoseOptimizerResult {
  bool success = false;  ///< true when Ceres ran and at least 3 inliers remained
  /// Refined pose (world -> camera). Equals the initial pose when !success.
  Eigen::Isometry3d T_camera_world = Eigen::Isometry3d::Identity();
  std::vector<bool> inliers;  ///< per observation: chi2 < chi2_threshold at the final pose
  int num_inliers = 0;        ///< count of true in `inliers`
  double rms_inlier_px = 0;   ///< RMS reprojection error of the inliers (not whitened) [px]
  /// The camera's angular and linear velocity during the frame, estimated with a rolling
  /// shutter; without one the start's (`rates_prior`) when the blur is weighted, else zero.
  CameraRates rates;
  /// The exposure the pixel residuals were weighted with [s]: motion_blur_exposure_ms when the
  /// motion model (`rates_prior`) turned at motion_blur_min_rate_rad_s or faster, else 0.
  double blur_exposure_s = 0.0;
  /// The velocities the solve took its blur weights and its velocity priors' widths at: the
  /// start's (`rates_prior` when used, else zero).
  CameraRates blur_rates;
  std::string message;  ///< why it failed; empty on success
};

/// The residuals PoseOptimizer::optimize minimises, built at one pose and one set of velocities
/// (PoseOptimizer::costsAt): what a covariance of its estimate is computed from.
struct PoseCosts {
  /// One cost per observation, in order (blocks: the quaternion of T_camera_world [x, y, z, w],
  /// its translation [m], and when `rolling` the angular [rad/s] and linear [m/s] velocity).
  std::vector<std::unique_ptr<ceres::CostFunction>> observations;
  bool rolling = false;  ///< the velocities are unknowns, with the priors below
  /// The widths of the velocities' priors [rad/s], [m/s]; 0 when !rolling.
  double omega_sigma_rad_s = 0.0;
  double velocity_sigma_m_s = 0.0;
  /// The virtual stereo depth_baseline_m * fx [px m]: hasDepthResidual(o, bf_px_m) says which
  /// costs have a third, depth residual.
  double bf_px_m = 0.0;
};

/// Minimises sum_j rho_huber(|e_j|^2 / sigma_j^2), e_j = uv_j - pi(T_camera_world P_j) (plus the
/// depth component u - b fx / z when the observation has a depth, see RgbdReprojectionError), over
/// the pose only, with Levenberg-Marquardt (Ceres, dense normal Cholesky, analytic Jacobians).
/// Outliers use chi2_threshold (2 dof) or chi2_threshold_depth (3 dof). Parameterisation: unit quaternion
/// (ceres::EigenQuaternionManifold) + translation. Outliers are handled as in ORB-SLAM: round 0 starts with every
/// observation in front of the camera; each of the `outlier_rounds` rounds runs up to `refine_iterations` LM steps
/// (Huber loss) on the current inliers and then re-classifies EVERY observation by chi2 at the new
/// pose, so an outlier can come back. The returned inliers are the last classification.
/// With a rolling shutter (rolling_shutter_readout_ms > 0 and observations with row times) the
/// camera's angular and linear velocity are unknowns too, with priors about the motion model's
/// (rolling_shutter_rate_sigma_rad_s, rolling_shutter_velocity_sigma_m_s), and each point is
/// projected with its row's camera (RollingShutterReprojectionError, analytic derivatives).
/// With an exposure (motion_blur_exposure_ms > 0) each pixel residual is whitened by its
/// keypoint's blur streak under the start's velocities (motion_blur.h), in the solve and in the
/// inlier test alike, when those velocities turn at motion_blur_min_rate_rad_s or faster.
class PoseOptimizer {
 public:
  /// Uses huber_px, refine_iterations, outlier_rounds, chi2_threshold, scale_factor.
  explicit PoseOptimizer(const TrackingOptions& options);

  /// Never throws on data: returns !success with a message when fewer than 3 observations are in
  /// front of the camera or Ceres fails.
  /// `rates_prior`: with a rolling shutter, the velocities the priors are centred on and the
  /// estimate starts from (the motion model's; zero when none); with an exposure, the velocities
  /// that set the blur.
  PoseOptimizerResult optimize(const std::vector<PoseObservation>& observations, const Pinhole& pinhole,
                               const Eigen::Isometry3d& T_camera_world_init,
                               const CameraRates& rates_prior = CameraRates()) const;

  /// True when `observation` is an inlier at `T_camera_world`: in front of the camera and its
  /// whitened chi2 under chi2_threshold (chi2_threshold_depth with the depth residual), the test
  /// optimize() classifies with.
  /// `rates`: the camera's velocities during the frame (PoseOptimizerResult), used with the
  /// observation's row time and, when they turn fast enough, for the blur's weight.
  bool agrees(const PoseObservation& observation, const Pinhole& pinhole, const Eigen::Isometry3d& T_camera_world,
              const CameraRates& rates = CameraRates()) const;
  /// The inlier test of the solve that gave `estimate` (its pose, velocities and blur weighting)
  /// for another observation.
  bool agrees(const PoseObservation& observation, const Pinhole& pinhole, const PoseOptimizerResult& estimate) const;

  /// The residuals optimize() builds for `observations`, each keypoint whitened by its level's
  /// sigma and by its blur over `exposure_s` (0 = sharp) at (T_camera_world, rates), and the widths
  /// of the velocity priors at `rates`. With a solve's blur_rates and blur_exposure_s
  /// (PoseOptimizerResult) and its pose, they are the residuals that solve minimised.
  PoseCosts costsAt(const std::vector<PoseObservation>& observations, const Pinhole& pinhole,
                    const Eigen::Isometry3d& T_camera_world, const CameraRates& rates, double exposure_s) const;

 private:
  double sigma(int level) const;
  /// agrees() with the point already in its row's camera frame, its blur weighted as by
  /// `exposure_s` (0: isotropic).
  bool agreesInCamera(const PoseObservation& observation, const Eigen::Vector3d& p_camera_m, const Pinhole& pinhole,
                      const CameraRates& rates, double exposure_s) const;
  /// motion_blur_exposure_ms in seconds when `rates` turn at motion_blur_min_rate_rad_s or
  /// faster, else 0 (no blur weights).
  double exposureS(const CameraRates& rates) const;
  /// True when the rolling shutter is modelled for `observations` (a readout and row times).
  bool rollingShutter(const std::vector<PoseObservation>& observations) const;
  /// The angular velocity prior's width about `rates`: the larger of
  /// rolling_shutter_rate_sigma_rad_s and rolling_shutter_rate_sigma_ratio times their turn rate.
  double omegaPriorSigma(const CameraRates& rates) const;
  /// One residual per observation: RgbdReprojectionError when it has a depth and
  /// depth_baseline_m > 0, else ReprojectionError; RollingShutterReprojectionError when
  /// `rolling`; whitened by sigma(level), and with an exposure by the keypoint's blur at the start
  /// pose and velocities (motion_blur.h; not the depth residual of RgbdReprojectionError, which
  /// stays isotropic).
  std::vector<std::unique_ptr<ceres::CostFunction>> makeCosts(const std::vector<PoseObservation>& observations,
                                                              const Pinhole& pinhole, bool rolling,
                                                              const Eigen::Isometry3d& T_camera_world_init,
                                                              const CameraRates& rates_init, double exposure_s) const;
  /// Marks each observation an inlier at (q_cw, t_cw, rates) in `inliers` (size of
  /// `observations`): in front of its row's camera when `accept_all_in_front`, else
  /// agreesInCamera; returns the count.
  int classify(const std::vector<PoseObservation>& observations, const Pinhole& pinhole, const Eigen::Quaterniond& q_cw,
               const Eigen::Vector3d& t_cw, const CameraRates& rates, double exposure_s, bool accept_all_in_front,
               std::vector<bool>* inliers) const;

  TrackingOptions options_;
  std::vector<double> level_sigma_;
};

}  // namespace tracking
}  // namespace dypho
