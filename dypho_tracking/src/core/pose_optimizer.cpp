#include "dypho/tracking/pose_optimizer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include "dypho/tracking/motion_blur.h"
#include "dypho/tracking/reprojection_error.h"

namespace dypho {
namespace tracking {

namespace {

/// The whitened squared residual of `o` with its point at `p_c` in the camera (in front of it):
/// the pixel residual times `sqrt_information`, plus with hasDepthResidual the virtual right
/// column's residual over sigma_px^2. What the inlier test compares with its chi2 thresholds.
double whitenedChi2(const PoseObservation& o, const Eigen::Vector3d& p_c, const Pinhole& pinhole,
                    const Eigen::Matrix2d& sqrt_information, double sigma_px, double bf) {
  const Eigen::Vector2d e = pinhole.project(p_c) - o.uv_px;
  double chi2 = (sqrt_information * e).squaredNorm();
  if (hasDepthResidual(o, bf)) {
    const double e_right = e.x() - bf / p_c.z() + bf / o.depth_m;
    chi2 += e_right * e_right / (sigma_px * sigma_px);
  }
  return chi2;
}

}  // namespace

PoseOptimizer::PoseOptimizer(const TrackingOptions& options) : options_(options) {
  options_.validate();
  level_sigma_.resize(static_cast<size_t>(options_.num_levels));
  for (int l = 0; l < options_.num_levels; ++l) {
    level_sigma_[static_cast<size_t>(l)] = std::pow(options_.scale_factor, l);
  }
}

double PoseOptimizer::sigma(int level) const {
  if (level >= 0 && level < static_cast<int>(level_sigma_.size())) return level_sigma_[static_cast<size_t>(level)];
  return std::pow(options_.scale_factor, std::max(0, level));
}

bool PoseOptimizer::agrees(const PoseObservation& o, const Pinhole& pinhole, const Eigen::Isometry3d& T_camera_world,
                           const CameraRates& rates) const {
  return agreesInCamera(o, pointAtRowTime(rates, o.row_time_s, T_camera_world * o.p_world_m), pinhole, rates,
                        exposureS(rates));
}

bool PoseOptimizer::agrees(const PoseObservation& o, const Pinhole& pinhole,
                           const PoseOptimizerResult& estimate) const {
  const CameraRates& rates = estimate.rates;
  return agreesInCamera(o, pointAtRowTime(rates, o.row_time_s, estimate.T_camera_world * o.p_world_m), pinhole, rates,
                        estimate.blur_exposure_s);
}

bool PoseOptimizer::rollingShutter(const std::vector<PoseObservation>& observations) const {
  if (!(options_.rolling_shutter_readout_ms > 0.0)) return false;
  for (const PoseObservation& o : observations) {
    if (o.row_time_s != 0.0) return true;
  }
  return false;
}

double PoseOptimizer::omegaPriorSigma(const CameraRates& rates) const {
  return std::max(options_.rolling_shutter_rate_sigma_rad_s,
                  options_.rolling_shutter_rate_sigma_ratio * rates.omega_rad_s.norm());
}

PoseCosts PoseOptimizer::costsAt(const std::vector<PoseObservation>& observations, const Pinhole& pinhole,
                                 const Eigen::Isometry3d& T_camera_world, const CameraRates& rates,
                                 double exposure_s) const {
  PoseCosts costs;
  costs.rolling = rollingShutter(observations);
  costs.observations = makeCosts(observations, pinhole, costs.rolling, T_camera_world, rates, exposure_s);
  if (costs.rolling) {
    costs.omega_sigma_rad_s = omegaPriorSigma(rates);
    costs.velocity_sigma_m_s = options_.rolling_shutter_velocity_sigma_m_s;
  }
  costs.bf_px_m = options_.depth_baseline_m * pinhole.fx;
  return costs;
}

double PoseOptimizer::exposureS(const CameraRates& rates) const {
  const bool turning = rates.omega_rad_s.allFinite() && rates.omega_rad_s.norm() >= options_.motion_blur_min_rate_rad_s;
  return turning ? std::max(0.0, options_.motion_blur_exposure_ms) * 1e-3 : 0.0;
}

bool PoseOptimizer::agreesInCamera(const PoseObservation& o, const Eigen::Vector3d& p_c, const Pinhole& pinhole,
                                   const CameraRates& rates, double exposure_s) const {
  if (!(p_c.z() > 1e-6)) return false;
  const double sigma_px = sigma(o.level);
  const double bf = options_.depth_baseline_m * pinhole.fx;
  const double chi2 =
      whitenedChi2(o, p_c, pinhole, blurSqrtInformation(p_c, rates, pinhole, exposure_s, sigma_px), sigma_px, bf);
  return chi2 < (hasDepthResidual(o, bf) ? options_.chi2_threshold_depth : options_.chi2_threshold);
}

std::vector<std::unique_ptr<ceres::CostFunction>> PoseOptimizer::makeCosts(
    const std::vector<PoseObservation>& observations, const Pinhole& pinhole, bool rolling,
    const Eigen::Isometry3d& T_camera_world_init, const CameraRates& rates_init, double exposure_s) const {
  const size_t n = observations.size();
  const double bf = options_.depth_baseline_m * pinhole.fx;
  const auto has_depth = [&](const PoseObservation& o) { return hasDepthResidual(o, bf); };
  std::vector<std::unique_ptr<ceres::CostFunction>> costs(n);
  for (size_t i = 0; i < n; ++i) {
    const PoseObservation& o = observations[i];
    // The blur's weight is fixed for the solve, from the start (the motion model's velocities);
    // without an exposure the point is not moved to the camera for it.
    Eigen::Matrix2d sqrt_information = Eigen::Matrix2d::Identity() / sigma(o.level);
    if (exposure_s > 0.0) {
      const Eigen::Vector3d p_c = pointAtRowTime(rates_init, o.row_time_s, T_camera_world_init * o.p_world_m);
      sqrt_information = blurSqrtInformation(p_c, rates_init, pinhole, exposure_s, sigma(o.level));
    }
    if (rolling) {
      costs[i] =
          std::make_unique<RollingShutterReprojectionError>(o.p_world_m, o.uv_px, has_depth(o) ? o.depth_m : 0.0, bf,
                                                            sigma(o.level), sqrt_information, o.row_time_s, pinhole);
    } else if (has_depth(o)) {
      costs[i] = std::make_unique<RgbdReprojectionError>(o.p_world_m, o.uv_px, o.depth_m, options_.depth_baseline_m,
                                                         sigma(o.level), pinhole);
    } else {
      costs[i] = std::make_unique<ReprojectionError>(o.p_world_m, o.uv_px, sqrt_information, pinhole);
    }
  }
  return costs;
}

int PoseOptimizer::classify(const std::vector<PoseObservation>& observations, const Pinhole& pinhole,
                            const Eigen::Quaterniond& q_cw, const Eigen::Vector3d& t_cw, const CameraRates& rates,
                            double exposure_s, bool accept_all_in_front, std::vector<bool>* inliers) const {
  int count = 0;
  for (size_t i = 0; i < observations.size(); ++i) {
    const Eigen::Vector3d p_c =
        pointAtRowTime(rates, observations[i].row_time_s, q_cw * observations[i].p_world_m + t_cw);
    const bool inlier =
        accept_all_in_front ? p_c.z() > 1e-6 : agreesInCamera(observations[i], p_c, pinhole, rates, exposure_s);
    (*inliers)[i] = inlier;
    count += inlier ? 1 : 0;
  }
  return count;
}

namespace {

/// What the outlier rounds share: the solver settings, and the loss and the manifold, which the
/// rounds' problems do not own.
struct RoundSetup {
  RoundSetup(double huber_px, int iterations) : loss(huber_px) {
    solver_options.minimizer_type = ceres::TRUST_REGION;
    solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
    solver_options.max_num_iterations = iterations;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    solver_options.minimizer_progress_to_stdout = false;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    // Each round's problem is built from the same two or four blocks and checked costs: Ceres's
    // per-residual checks (duplicate blocks, sizes) were a quarter of the ~1300 instructions that
    // adding a residual cost (about 10 problems of a few hundred residuals per frame).
    problem_options.disable_all_safety_checks = true;
  }
  ceres::Solver::Options solver_options;
  ceres::HuberLoss loss;
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::Problem::Options problem_options;
};

/// The velocities of a rolling shutter as unknowns: their blocks and their priors.
struct RateUnknown {
  CameraRates* rates = nullptr;                ///< null: global shutter, the costs take two blocks
  ceres::CostFunction* omega_prior = nullptr;  ///< RatePrior, owned by the caller
  ceres::CostFunction* velocity_prior = nullptr;
};

/// One round: Levenberg-Marquardt on the residuals of the current inliers, from (q_cw, t_cw) and
/// the rate in place. False, with Ceres's message, when the solution is unusable or not finite.
bool solveRound(const std::vector<std::unique_ptr<ceres::CostFunction>>& costs, const std::vector<bool>& inliers,
                RoundSetup* setup, Eigen::Quaterniond* q_cw, Eigen::Vector3d* t_cw, const RateUnknown& rate,
                std::string* failure) {
  ceres::Problem problem(setup->problem_options);
  problem.AddParameterBlock(q_cw->coeffs().data(), 4, &setup->quaternion_manifold);
  problem.AddParameterBlock(t_cw->data(), 3);
  double* omega = rate.rates != nullptr ? rate.rates->omega_rad_s.data() : nullptr;
  double* velocity = rate.rates != nullptr ? rate.rates->velocity_m_s.data() : nullptr;
  if (rate.rates != nullptr) {
    problem.AddParameterBlock(omega, 3);
    problem.AddParameterBlock(velocity, 3);
    problem.AddResidualBlock(rate.omega_prior, nullptr, omega);
    problem.AddResidualBlock(rate.velocity_prior, nullptr, velocity);
  }
  for (size_t i = 0; i < costs.size(); ++i) {
    if (!inliers[i]) continue;
    if (rate.rates != nullptr) {
      problem.AddResidualBlock(costs[i].get(), &setup->loss, q_cw->coeffs().data(), t_cw->data(), omega, velocity);
    } else {
      problem.AddResidualBlock(costs[i].get(), &setup->loss, q_cw->coeffs().data(), t_cw->data());
    }
  }
  ceres::Solver::Summary summary;
  ceres::Solve(setup->solver_options, &problem, &summary);
  const bool rate_finite =
      rate.rates == nullptr || (rate.rates->omega_rad_s.allFinite() && rate.rates->velocity_m_s.allFinite());
  if (!summary.IsSolutionUsable() || !q_cw->coeffs().allFinite() || !t_cw->allFinite() || !rate_finite) {
    *failure = "Ceres failed: " + summary.message;
    return false;
  }
  return true;
}

/// RMS reprojection error of the inliers at (q_cw, t_cw), not whitened [px]; 0 without inliers.
double rmsInlierPx(const std::vector<PoseObservation>& observations, const std::vector<bool>& inliers, int active,
                   const Pinhole& pinhole, const Eigen::Quaterniond& q_cw, const Eigen::Vector3d& t_cw,
                   const CameraRates& rates) {
  double sum_sq = 0;
  for (size_t i = 0; i < observations.size(); ++i) {
    if (!inliers[i]) continue;
    const Eigen::Vector3d p_c =
        pointAtRowTime(rates, observations[i].row_time_s, q_cw * observations[i].p_world_m + t_cw);
    sum_sq += (pinhole.project(p_c) - observations[i].uv_px).squaredNorm();
  }
  return active > 0 ? std::sqrt(sum_sq / active) : 0.0;
}

}  // namespace

PoseOptimizerResult PoseOptimizer::optimize(const std::vector<PoseObservation>& observations, const Pinhole& pinhole,
                                            const Eigen::Isometry3d& T_camera_world_init,
                                            const CameraRates& rates_prior) const {
  PoseOptimizerResult result;
  result.T_camera_world = T_camera_world_init;
  const size_t n = observations.size();
  result.inliers.assign(n, false);

  Eigen::Quaterniond q_cw(T_camera_world_init.rotation());
  q_cw.normalize();
  Eigen::Vector3d t_cw = T_camera_world_init.translation();
  if (!q_cw.coeffs().allFinite() || !t_cw.allFinite()) {
    result.message = "initial pose is not finite";
    return result;
  }
  // The residuals, the loss and the manifold are built once and shared by the rounds' problems,
  // which do not own them: a round only chooses which residuals take part. (Allocating them again
  // each round cost more than the solve on a small problem.)
  const bool rolling = rollingShutter(observations);
  // The blur's weighting is chosen once, by the motion model's turn rate, for the solve and the
  // inlier tests alike. The velocities: unknowns with a rolling shutter, else the motion model's,
  // held fixed (they only set the blur's weights; global-shutter observations have row time 0).
  const double exposure_s = exposureS(rates_prior);
  result.blur_exposure_s = exposure_s;
  CameraRates rates;
  if (rolling || exposure_s > 0.0) {
    if (rates_prior.omega_rad_s.allFinite()) rates.omega_rad_s = rates_prior.omega_rad_s;
    if (rates_prior.velocity_m_s.allFinite()) rates.velocity_m_s = rates_prior.velocity_m_s;
  }
  const std::vector<std::unique_ptr<ceres::CostFunction>> costs =
      makeCosts(observations, pinhole, rolling, T_camera_world_init, rates, exposure_s);
  result.blur_rates = rates;  // the start's: the weights and the priors' widths were taken there
  RoundSetup setup(options_.huber_px, options_.refine_iterations);
  std::unique_ptr<ceres::CostFunction> omega_prior, velocity_prior;
  RateUnknown rate;
  if (rolling) {
    omega_prior = std::make_unique<RatePrior>(rates.omega_rad_s, omegaPriorSigma(rates));
    velocity_prior = std::make_unique<RatePrior>(rates.velocity_m_s, options_.rolling_shutter_velocity_sigma_m_s);
    rate = RateUnknown{&rates, omega_prior.get(), velocity_prior.get()};
  }

  // Round 0 uses every observation in front of the camera (Huber bounds the outliers' pull).
  int active =
      classify(observations, pinhole, q_cw, t_cw, rates, exposure_s, /*accept_all_in_front=*/true, &result.inliers);
  for (int round = 0; round < options_.outlier_rounds; ++round) {
    if (active < 3) {
      result.message =
          "only " + std::to_string(active) + " observations left in front of the camera / below the chi2 threshold";
      result.T_camera_world = T_camera_world_init;
      result.num_inliers = 0;
      return result;
    }
    if (!solveRound(costs, result.inliers, &setup, &q_cw, &t_cw, rate, &result.message)) {
      result.T_camera_world = T_camera_world_init;
      result.inliers.assign(n, false);
      result.num_inliers = 0;
      return result;
    }
    q_cw.normalize();
    active =
        classify(observations, pinhole, q_cw, t_cw, rates, exposure_s, /*accept_all_in_front=*/false, &result.inliers);
  }

  result.num_inliers = active;
  result.success = active >= 3;
  if (!result.success) result.message = "fewer than 3 inliers after the last round";
  result.T_camera_world = Eigen::Isometry3d::Identity();
  result.T_camera_world.linear() = q_cw.toRotationMatrix();
  result.T_camera_world.translation() = t_cw;
  result.rms_inlier_px = rmsInlierPx(observations, result.inliers, active, pinhole, q_cw, t_cw, rates);
  result.rates = rates;
  return result;
}

}  // namespace tracking
}  // namespace dypho
