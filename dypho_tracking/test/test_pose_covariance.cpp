/// The pose covariance against the scatter of the motion-only estimate itself (Monte Carlo).
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "dypho/tracking/motion_blur.h"
#include "dypho/tracking/pose_covariance.h"
#include "dypho/tracking/pose_optimizer.h"
#include "dypho/tracking/rolling_shutter.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

const Pinhole kPinhole{525.0, 525.0, 319.5, 239.5};

/// World -> camera: turned 1.2 rad about a slanted axis and moved, so that the world frame's axes
/// differ from the camera's and a wrong frame change shows.
Eigen::Isometry3d truePose() {
  return Eigen::Translation3d(0.2, -0.3, 0.5) * Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.3, 1.0, -0.2).normalized());
}

/// How the frame was taken: the camera's true velocities during it, its rolling shutter's readout
/// and its exposure (all zero: a still camera, a global shutter, sharp keypoints), and the
/// tracker's options that model them.
struct Capture {
  CameraRates rates;
  double readout_s = 0.0;
  double exposure_s = 0.0;
  TrackingOptions options;
};

/// A fast hand-held turn as fr1/rpy's fastest (2.6 rad/s, 0.06 m/s), read out over 30 ms (the
/// TUM and Bonn camera files') and blurred over the default exposure (4 ms: streaks of about 5
/// px), modelled as such.
Capture fastTurn() {
  Capture c;
  c.rates.omega_rad_s = Eigen::Vector3d(0.5, 2.5, 0.3);
  c.rates.velocity_m_s = Eigen::Vector3d(0.05, -0.02, 0.03);
  c.readout_s = 0.030;
  c.options.rolling_shutter_readout_ms = 1e3 * c.readout_s;
  c.exposure_s = 1e-3 * c.options.motion_blur_exposure_ms;
  return c;
}

/// `count` points seen at pixels uniform in [u0, u1] x [v0, v1] and depths uniform in [z0, z1],
/// exact (no noise) at truePose() in their rows' cameras under `capture`, all at pyramid level 0
/// (sigma 1 px).
std::vector<PoseObservation> scene(int count, double u0, double u1, double v0, double v1, double z0, double z1,
                                   std::mt19937* rng, const Capture& capture = Capture()) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<PoseObservation> observations;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector2d uv(u0 + (u1 - u0) * u01(*rng), v0 + (v1 - v0) * u01(*rng));
    const double z = z0 + (z1 - z0) * u01(*rng);
    PoseObservation o;
    o.uv_px = uv;
    o.row_time_s = capture.readout_s > 0.0 ? rowTimeOffsetS(uv.y(), 480, capture.readout_s) : 0.0;
    const Eigen::Vector3d p_row((uv.x() - kPinhole.cx) / kPinhole.fx * z, (uv.y() - kPinhole.cy) / kPinhole.fy * z, z);
    // p_row = exp(-omega tau) (p_stamp - v tau), inverted.
    const double tau = o.row_time_s;
    const Eigen::Vector3d turn = tau * capture.rates.omega_rad_s;
    const Eigen::Vector3d p_stamp =
        (turn.norm() > 0.0 ? Eigen::AngleAxisd(turn.norm(), turn.normalized()) * p_row : p_row) +
        tau * capture.rates.velocity_m_s;
    o.p_world_m = truePose().inverse() * p_stamp;
    observations.push_back(o);
  }
  return observations;
}

struct Scatter {
  Eigen::Matrix<double, 6, 6> empirical = Eigen::Matrix<double, 6, 6>::Zero();  ///< about the truth
  Eigen::Matrix<double, 6, 6> predicted = Eigen::Matrix<double, 6, 6>::Zero();  ///< mean reported
};

/// `trials` estimates of the pose from `exact` with noise_px Gaussian pixel noise, stretched along
/// each keypoint's blur streak under `capture`, and, with a rolling shutter, the velocities'
/// priors centred on the truth plus their own noise: the scatter of (centre, rotation about the
/// world axes) about the truth and the mean reported covariance.
Scatter monteCarlo(const std::vector<PoseObservation>& exact, double noise_px, int trials, std::mt19937* rng,
                   const Capture& capture = Capture()) {
  const PoseOptimizer optimizer{capture.options};
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto gaussian3 = [&]() { return Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)); };
  const Eigen::Isometry3d T_world_camera_true = truePose().inverse();
  const double omega_sigma =
      std::max(capture.options.rolling_shutter_rate_sigma_rad_s,
               capture.options.rolling_shutter_rate_sigma_ratio * capture.rates.omega_rad_s.norm());
  Scatter s;
  int used = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<PoseObservation> noisy = exact;
    for (PoseObservation& o : noisy) {
      const Eigen::Vector3d p_c = pointAtRowTime(capture.rates, o.row_time_s, truePose() * o.p_world_m);
      const Eigen::Matrix2d W = blurSqrtInformation(p_c, capture.rates, kPinhole, capture.exposure_s, noise_px);
      o.uv_px += W.inverse() * Eigen::Vector2d(normal(*rng), normal(*rng));
    }
    CameraRates prior = capture.rates;
    if (capture.readout_s > 0.0) {
      prior.omega_rad_s += omega_sigma * gaussian3();
      prior.velocity_m_s += capture.options.rolling_shutter_velocity_sigma_m_s * gaussian3();
    }
    const PoseOptimizerResult r = optimizer.optimize(noisy, kPinhole, truePose(), prior);
    if (!r.success) continue;
    std::vector<PoseObservation> inliers;
    for (std::size_t i = 0; i < noisy.size(); ++i) {
      if (r.inliers[i]) inliers.push_back(noisy[i]);
    }
    const PoseCovariance c =
        poseCovariance(optimizer, inliers, kPinhole, r.T_camera_world, r.rates, r.blur_rates, r.blur_exposure_s);
    if (!c.valid) continue;
    const Eigen::Isometry3d T_world_camera = r.T_camera_world.inverse();
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = T_world_camera.translation() - T_world_camera_true.translation();
    const Eigen::AngleAxisd turn(T_world_camera.rotation() * T_world_camera_true.rotation().transpose());
    e.tail<3>() = turn.angle() * turn.axis();
    s.empirical += e * e.transpose();
    s.predicted += c.world;
    ++used;
  }
  EXPECT_GE(used, trials * 9 / 10) << "estimates without a valid covariance";
  s.empirical /= std::max(1, used);
  s.predicted /= std::max(1, used);
  return s;
}

/// The eigenvalues of the scatter whitened by the reported covariance, P^-1/2 E P^-1/2: all 1
/// when the covariance describes the scatter, in every direction and coupling.
Eigen::Matrix<double, 6, 1> whitenedScatter(const Scatter& s) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> p(s.predicted);
  const Eigen::Matrix<double, 6, 6> inverse_root =
      p.eigenvectors() * p.eigenvalues().cwiseSqrt().cwiseInverse().asDiagonal() * p.eigenvectors().transpose();
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(inverse_root * s.empirical * inverse_root)
      .eigenvalues();
}

/// Each scene's scatter, whitened by the reported covariance, must have all six eigenvalues in
/// [0.75, 1.33]. 1000 trials: a 6 x 6 sample covariance of white scatter has its eigenvalues
/// within (1 -+ sqrt(6 / 1000))^2 = [0.85, 1.16] (Marchenko-Pastur), so the bound leaves about
/// twice that spread. A covariance left in the camera frame (wrong by a 1.2 rad turn on the far
/// patch's 30:1 anisotropy), a missing sign in the frame change (the centre-rotation coupling),
/// or a rotation taken as 2x (a quaternion's half angle) misses it by far more.
TEST(PoseCovariance, MatchesTheScatterOfTheEstimate) {
  std::mt19937 rng(11);
  struct Case {
    const char* name;
    std::vector<PoseObservation> points;
  };
  const std::vector<Case> cases = {
      {"spread over the view, 1-5 m", scene(150, 20, 620, 20, 460, 1.0, 5.0, &rng)},
      // A small patch of a far wall: a sideways shift looks like a turn.
      {"a far patch, 3-3.6 m", scene(150, 260, 380, 200, 290, 3.0, 3.6, &rng)},
  };
  double max_sigma_m[2] = {0.0, 0.0};
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const Scatter s = monteCarlo(cases[k].points, 1.0, 1000, &rng);
    const Eigen::Matrix<double, 6, 1> eigenvalues = whitenedScatter(s);
    EXPECT_GT(eigenvalues.minCoeff(), 0.75) << cases[k].name << ": " << eigenvalues.transpose();
    EXPECT_LT(eigenvalues.maxCoeff(), 1.33) << cases[k].name << ": " << eigenvalues.transpose();
    max_sigma_m[k] =
        std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(s.predicted.topLeftCorner<3, 3>()).eigenvalues()(2));
  }
  // The far patch leaves the centre far less certain (its shift-turn ambiguity).
  EXPECT_GT(max_sigma_m[1], 5.0 * max_sigma_m[0]) << max_sigma_m[0] << " m vs " << max_sigma_m[1] << " m";
}

/// The same on a fast turn with a rolling shutter and blur: the solve estimates the velocities
/// with the pose, under priors whose centres (the motion model's) are off by their own widths, and
/// weighs each keypoint by its streak. The covariance must carry both: the velocities'
/// uncertainty passes into the pose, and the streaks leave the pose less certain along the image
/// motion. Bound: a factor 1.5 either way in every direction, wider than above as the solve is
/// not linear-Gaussian here (Huber at 2 sigma, the inliers trimmed by chi2, streaks and prior
/// widths taken at noisy centres); measured 0.94-1.23 over both scenes. With the velocities held
/// at their estimate the covariance misses it by 3.1-3.3 in its worst direction, and with
/// isotropic keypoints as well by 3.4.
TEST(PoseCovariance, MatchesTheScatterOnAFastTurnWithARollingShutter) {
  std::mt19937 rng(17);
  const Capture turn = fastTurn();
  struct Case {
    const char* name;
    std::vector<PoseObservation> points;
  };
  const std::vector<Case> cases = {
      {"spread over the view, 1-5 m", scene(150, 20, 620, 20, 460, 1.0, 5.0, &rng, turn)},
      {"a far patch, 3-3.6 m", scene(150, 260, 380, 200, 290, 3.0, 3.6, &rng, turn)},
  };
  for (const Case& c : cases) {
    const Eigen::Matrix<double, 6, 1> eigenvalues = whitenedScatter(monteCarlo(c.points, 1.0, 1000, &rng, turn));
    EXPECT_GT(eigenvalues.minCoeff(), 0.67) << c.name << ": " << eigenvalues.transpose();
    EXPECT_LT(eigenvalues.maxCoeff(), 1.5) << c.name << ": " << eigenvalues.transpose();
  }
}

/// Residuals of 2 px on a 1 px model: the reported covariance grows by their variance factor.
/// 400 points give 800 residuals, whose mean square estimates 4 to sqrt(2 / 794) = 5 %; bound
/// [3.4, 4.6] is 3 standard deviations.
TEST(PoseCovariance, ScalesWithTheResidualsNotBelowTheModel) {
  std::mt19937 rng(5);
  const PoseOptimizer optimizer{TrackingOptions()};
  const std::vector<PoseObservation> exact = scene(400, 20, 620, 20, 460, 1.0, 5.0, &rng);
  std::normal_distribution<double> noise(0.0, 2.0);
  std::vector<PoseObservation> noisy = exact;
  for (PoseObservation& o : noisy) o.uv_px += Eigen::Vector2d(noise(rng), noise(rng));
  const PoseCovariance at_model =
      poseCovariance(optimizer, exact, kPinhole, truePose(), CameraRates(), CameraRates(), 0.0);
  const PoseCovariance scaled =
      poseCovariance(optimizer, noisy, kPinhole, truePose(), CameraRates(), CameraRates(), 0.0);
  ASSERT_TRUE(at_model.valid);
  ASSERT_TRUE(scaled.valid);
  EXPECT_DOUBLE_EQ(at_model.variance_factor, 1.0) << "exact residuals: never below the pixel model";
  EXPECT_GT(scaled.variance_factor, 3.4);
  EXPECT_LT(scaled.variance_factor, 4.6);
  EXPECT_NEAR(scaled.world(0, 0) / at_model.world(0, 0), scaled.variance_factor, 1e-9);
}

/// Two points, or points that all lie on the optical axis's ray, leave the pose free: invalid.
TEST(PoseCovariance, InvalidWhenThePointsLeaveThePoseFree) {
  std::mt19937 rng(3);
  const PoseOptimizer optimizer{TrackingOptions()};
  const std::vector<PoseObservation> points = scene(2, 20, 620, 20, 460, 1.0, 5.0, &rng);
  EXPECT_FALSE(poseCovariance(optimizer, points, kPinhole, truePose(), CameraRates(), CameraRates(), 0.0).valid);
  std::vector<PoseObservation> one_ray = scene(50, 319.5, 319.5, 239.5, 239.5, 1.0, 5.0, &rng);
  const PoseCovariance c = poseCovariance(optimizer, one_ray, kPinhole, truePose(), CameraRates(), CameraRates(), 0.0);
  EXPECT_FALSE(c.valid);
  EXPECT_EQ(c.maxPositionSigmaM(), 0.0);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
