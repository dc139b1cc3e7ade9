/// The bundle-adjustment machinery shared by the local and the global adjuster.
#include "bundle_adjustment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include "dypho/tracking/motion_blur.h"
#include "dypho/tracking/reprojection_error.h"

namespace dypho {
namespace tracking {
namespace {

/// Pose of one keyframe as Ceres parameters (T_camera_world).
struct PoseBlock {
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
  bool fixed = false;
};

struct Observation {
  std::int64_t keyframe_id;
  std::int64_t point_id;
  int feature_index;
  ceres::ResidualBlockId block;
  const BaRgbdError* cost;                  ///< owned by the problem
  std::array<const double*, 3> parameters;  ///< q, t of its keyframe, its point
};

/// The Ceres problem of one window: the parameter blocks it optimises in place (the points start
/// as the input's) and what its residual blocks stand for. Built in place and never moved (Ceres
/// keeps pointers into it).
struct BaWindow {
  BaWindow(const LocalBaProblem& input, const ceres::Problem::Options& options)
      : points(input.p_world_m), problem(options) {}
  std::map<std::int64_t, PoseBlock> poses;
  std::unordered_map<std::int64_t, Eigen::Vector3d> points;
  ceres::Problem problem;
  std::vector<Observation> observations;
  std::vector<std::size_t> source;  // index into input.observations
};

/// The window's keyframe poses as T_camera_world parameter blocks (normalised quaternion).
void addPoseBlocks(const LocalBaProblem& input, BaWindow* window) {
  for (const auto& [id, T_world_keyframe] : input.T_world_keyframe) {
    const Eigen::Isometry3d T_cw = T_world_keyframe.inverse();
    window->poses[id] = {Eigen::Quaterniond(T_cw.rotation()).normalized(), T_cw.translation(), input.fixed.at(id)};
  }
}

/// A BaRgbdError per observation in front of its keyframe (with its depth term where measured,
/// when local_ba_depth_baseline_m > 0), whitened by scale_factor^level, a Huber loss (huber_px)
/// on its pixel part and one on its depth part (inside the block).
void addResiduals(const LocalBaProblem& input, const TrackingOptions& options, BaWindow* window) {
  const Pinhole& pinhole = input.pinhole;
  std::vector<double> level_sigma(static_cast<size_t>(options.num_levels));
  for (int l = 0; l < options.num_levels; ++l) {
    level_sigma[static_cast<size_t>(l)] = std::pow(options.scale_factor, l);
  }
  const double bf = options.local_ba_depth_baseline_m * pinhole.fx;
  for (std::size_t k = 0; k < input.observations.size(); ++k) {
    const LocalBaObservation& o = input.observations[k];
    PoseBlock& pose = window->poses.at(o.keyframe_id);
    Eigen::Vector3d& p = window->points.at(o.point_id);
    const double sigma = level_sigma[static_cast<size_t>(o.level)];
    // Skip observations behind the camera at the start (would make Evaluate fail).
    const Eigen::Vector3d p_c = pose.q * p + pose.t;
    if (!(p_c.z() > 1e-3)) continue;
    auto* cost = new BaRgbdError(o.uv_px, streakSqrtInformation(o.blur_streak_px, sigma), pinhole, o.depth_m, bf, sigma,
                                 options.huber_px);
    const auto block = window->problem.AddResidualBlock(cost, nullptr, pose.q.coeffs().data(), pose.t.data(), p.data());
    window->observations.push_back(
        {o.keyframe_id, o.point_id, o.feature_index, block, cost, {pose.q.coeffs().data(), pose.t.data(), p.data()}});
    window->source.push_back(k);
  }
}

/// The problem's keyframe-pair priors (newBaRelativePoseError, no loss) between keyframes of the
/// window; a pair of two fixed keyframes is left out.
void addPosePriors(const LocalBaProblem& input, BaWindow* window) {
  for (const KeyframePairPrior& prior : input.pose_priors) {
    const auto a = window->poses.find(prior.from);
    const auto b = window->poses.find(prior.to);
    if (a == window->poses.end() || b == window->poses.end() || (a->second.fixed && b->second.fixed)) continue;
    window->problem.AddResidualBlock(newBaRelativePoseError(prior.T_from_to, prior.sigma_rot_rad, prior.sigma_trans_m),
                                     nullptr, a->second.q.coeffs().data(), a->second.t.data(),
                                     b->second.q.coeffs().data(), b->second.t.data());
  }
}

/// Quaternion manifolds on the poses in the problem; the fixed ones held constant.
void setPoseManifolds(BaWindow* window) {
  ceres::Problem& problem = window->problem;
  for (auto& kv : window->poses) {
    if (!problem.HasParameterBlock(kv.second.q.coeffs().data())) continue;
    problem.SetManifold(kv.second.q.coeffs().data(), new ceres::EigenQuaternionManifold());
    if (kv.second.fixed) {
      problem.SetParameterBlockConstant(kv.second.q.coeffs().data());
      problem.SetParameterBlockConstant(kv.second.t.data());
    }
  }
}

/// Levenberg-Marquardt, `settings.iterations` steps at most, one thread, silent.
ceres::Solver::Options baSolverOptions(const BaSolverSettings& settings) {
  ceres::Solver::Options so;
  // Dense Schur complement for a local window: its reduced camera system (a few keyframes, 6
  // parameters each) is tiny, and the sparse solver's symbolic analysis on every solve cost more
  // than the whole dense factorisation (a keyframe's tracking 25-35 % faster, the same poses).
  // Sparse Schur for the whole map: the reduced system of hundreds of keyframes is sparse
  // (covisibility), and dense would grow with the cube of the keyframes.
  so.linear_solver_type = ceres::DENSE_SCHUR;
  if (settings.sparse && ceres::IsSparseLinearAlgebraLibraryTypeAvailable(so.sparse_linear_algebra_library_type)) {
    so.linear_solver_type = ceres::SPARSE_SCHUR;
  }
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.max_num_iterations = settings.iterations;
  if (settings.max_seconds_per_round > 0.0) so.max_solver_time_in_seconds = settings.max_seconds_per_round;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  return so;
}

/// Removes the observations over the chi2 threshold (chi2_threshold_depth with a depth term) from
/// the problem and appends them to `outliers`.
void removeChi2Outliers(const LocalBaProblem& input, const TrackingOptions& options, BaWindow* window,
                        std::vector<LocalBaObservation>* outliers) {
  ceres::Problem& problem = window->problem;
  const std::vector<Observation>& observations = window->observations;
  for (size_t k = 0; k < observations.size(); ++k) {
    double r[3];
    const bool ok = observations[k].cost->rawResiduals(observations[k].parameters.data(), r);
    const double chi2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    const double threshold = observations[k].cost->hasDepth() ? options.chi2_threshold_depth : options.chi2_threshold;
    if (!ok || chi2 > threshold) {
      outliers->push_back(input.observations[window->source[k]]);
      problem.RemoveResidualBlock(observations[k].block);
    }
  }
}

/// The free keyframes' poses (T_world_keyframe) and the finite points into `solution`.
void writeSolution(const BaWindow& window, LocalBaSolution* solution) {
  for (const auto& kv : window.poses) {
    if (kv.second.fixed) continue;
    Eigen::Isometry3d T_cw = Eigen::Isometry3d::Identity();
    T_cw.linear() = kv.second.q.normalized().toRotationMatrix();
    T_cw.translation() = kv.second.t;
    if (!T_cw.matrix().allFinite()) continue;
    solution->T_world_keyframe[kv.first] = T_cw.inverse();
  }
  for (const auto& kv : window.points) {
    if (kv.second.allFinite()) solution->p_world_m.insert(kv);
  }
  solution->fixed_keyframes = static_cast<int>(window.poses.size() - solution->T_world_keyframe.size());
  solution->observations = static_cast<int>(window.observations.size());
}

/// The single-view points of the free keyframes, moved rigidly with them.
void moveSingleViewPoints(const LocalBaProblem& input, LocalBaSolution* solution) {
  for (const SingleViewPoint& single : input.single_view_points) {
    const auto moved = solution->T_world_keyframe.find(single.keyframe_id);
    if (moved == solution->T_world_keyframe.end()) continue;  // a fixed keyframe's: it stays
    const Eigen::Isometry3d move = moved->second * input.T_world_keyframe.at(single.keyframe_id).inverse();
    solution->p_world_single_view_m[single.point_id] = move * single.p_world_m;
  }
}

}  // namespace

void addBaPoints(const TrackerMap& map, const std::set<std::int64_t>& point_ids, LocalBaProblem* problem) {
  // How many keyframes of the problem see each point (the observations addBaObservations makes),
  // and the last of them.
  struct Seen {
    int keyframes = 0;
    std::int64_t keyframe_id = -1;
  };
  std::unordered_map<std::int64_t, Seen> seen_by;
  for (const auto& kv : problem->T_world_keyframe) {
    for (std::int64_t id : map.keyframe(kv.first)->map_point_ids) {
      if (point_ids.count(id) == 0) continue;
      Seen& seen = seen_by[id];
      ++seen.keyframes;
      seen.keyframe_id = kv.first;
    }
  }
  for (std::int64_t id : point_ids) {
    const Eigen::Vector3d& p_world_m = map.point(id)->p_world_m;
    const auto seen = seen_by.find(id);
    if (seen != seen_by.end() && seen->second.keyframes == 1) {
      problem->single_view_points.push_back({id, seen->second.keyframe_id, p_world_m});
    } else {
      problem->p_world_m[id] = p_world_m;
    }
  }
}

void addBaObservations(const TrackerMap& map, const TrackingOptions& options, LocalBaProblem* problem) {
  for (const auto& kv : problem->T_world_keyframe) {
    const MapKeyframe* kf = map.keyframe(kv.first);
    const bool blurred = options.motion_blur_in_bundle_adjustment && kf->blur_exposure_s > 0.0;
    const Eigen::Isometry3d T_camera_world = kv.second.inverse();
    for (size_t i = 0; i < kf->map_point_ids.size(); ++i) {
      if (problem->p_world_m.count(kf->map_point_ids[i]) == 0) continue;
      LocalBaObservation o;
      o.keyframe_id = kv.first;
      o.point_id = kf->map_point_ids[i];
      o.feature_index = static_cast<int>(i);
      o.uv_px = kf->features.uv_undistorted_px[i];
      o.level = std::clamp(kf->features.keypoints[i].octave, 0, options.num_levels - 1);
      o.depth_m = kf->features.depth_m[i];
      if (blurred) {
        const Eigen::Vector3d p_camera_m = T_camera_world * problem->p_world_m.at(o.point_id);
        o.blur_streak_px = imageVelocityPxS(p_camera_m, kf->blur_rates, problem->pinhole) * kf->blur_exposure_s;
      }
      problem->observations.push_back(o);
    }
  }
}

LocalBaSolution solveBundleAdjustment(const LocalBaProblem& input, const TrackingOptions& options,
                                      const BaSolverSettings& settings) {
  LocalBaSolution solution;
  solution.newest_keyframe_id = input.newest_keyframe_id;
  if (!input.message.empty()) {
    solution.message = input.message;
    return solution;
  }
  ceres::Problem::Options po;
  po.enable_fast_removal = true;
  BaWindow window(input, po);
  addPoseBlocks(input, &window);
  addResiduals(input, options, &window);
  if (window.observations.empty()) {
    solution.message = "no observations";
    return solution;
  }
  addPosePriors(input, &window);
  setPoseManifolds(&window);
  const ceres::Solver::Options so = baSolverOptions(settings);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &window.problem, &summary);
  if (!summary.IsSolutionUsable()) {
    solution.message = "Ceres failed: " + summary.message;
    return solution;
  }
  // Remove chi2 outliers, then a second round.
  removeChi2Outliers(input, options, &window, &solution.outliers);
  ceres::Solve(so, &window.problem, &summary);
  if (!summary.IsSolutionUsable()) {
    solution.message = "Ceres failed in round 2: " + summary.message;
    return solution;
  }
  writeSolution(window, &solution);
  moveSingleViewPoints(input, &solution);
  solution.usable = true;
  return solution;
}

LocalBaResult applyBundleAdjustment(const LocalBaSolution& solution, TrackerMap* map) {
  LocalBaResult result;
  if (!solution.usable) {
    result.message = solution.message;
    return result;
  }
  for (const auto& [id, T_world_keyframe] : solution.T_world_keyframe) {
    MapKeyframe* kf = map->mutableKeyframe(id);
    if (kf == nullptr) continue;  // removed since the window was prepared
    kf->T_world_camera = T_world_keyframe;
    ++result.optimized_keyframes;
  }
  for (const auto* points : {&solution.p_world_m, &solution.p_world_single_view_m}) {
    for (const auto& [id, p_world_m] : *points) {
      if (MapPoint* p = map->mutablePoint(id)) p->p_world_m = p_world_m;
    }
  }
  for (const LocalBaObservation& o : solution.outliers) {
    MapPoint* p = map->mutablePoint(o.point_id);
    MapKeyframe* kf = map->mutableKeyframe(o.keyframe_id);
    if (p == nullptr || kf == nullptr || p->observations.size() <= 1) continue;  // keep sole obs
    const auto index = static_cast<size_t>(o.feature_index);
    if (index >= kf->map_point_ids.size() || kf->map_point_ids[index] != o.point_id) continue;  // re-assigned
    p->observations.erase(o.keyframe_id);
    kf->map_point_ids[index] = -1;
    ++result.removed_observations;
  }
  result.fixed_keyframes = solution.fixed_keyframes;
  result.points = static_cast<int>(solution.p_world_m.size());
  result.single_view_points = static_cast<int>(solution.p_world_single_view_m.size());
  result.observations = solution.observations;
  result.ran = true;
  return result;
}

}  // namespace tracking
}  // namespace dypho
