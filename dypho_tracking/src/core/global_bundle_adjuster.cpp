#include "dypho/tracking/global_bundle_adjuster.h"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <set>
#include <sstream>
#include <vector>

#include "bundle_adjustment.h"

namespace dypho {
namespace tracking {

namespace {

/// A prior on the relative pose of each keyframe and the next (by id) as the map has it now, with
/// global_ba_prior_sigma_deg / _m; none when either is 0, nor into the first keyframe of a
/// segment in `extra_fixed` (its pose is not tied to the one before).
void addKeyframePairPriors(const TrackerMap& map, const TrackingOptions& options,
                           const std::set<std::int64_t>& extra_fixed, LocalBaProblem* problem) {
  if (!(options.global_ba_prior_sigma_deg > 0.0) || !(options.global_ba_prior_sigma_m > 0.0)) return;
  const MapKeyframe* previous = nullptr;
  for (const auto& [id, keyframe] : map.keyframes()) {
    if (previous != nullptr && extra_fixed.count(id) == 0) {
      KeyframePairPrior prior;
      prior.from = previous->id;
      prior.to = id;
      prior.T_from_to = previous->T_world_camera.inverse() * keyframe.T_world_camera;
      prior.sigma_rot_rad = options.global_ba_prior_sigma_deg * M_PI / 180.0;
      prior.sigma_trans_m = options.global_ba_prior_sigma_m;
      problem->pose_priors.push_back(prior);
    }
    previous = &keyframe;
  }
}

}  // namespace

GlobalBundleAdjuster::GlobalBundleAdjuster(const TrackingOptions& options) : options_(options) { options_.validate(); }

GlobalBaResult GlobalBundleAdjuster::adjust(TrackerMap* map, const Pinhole& pinhole,
                                            const std::set<std::int64_t>& extra_fixed) const {
  const auto t0 = std::chrono::steady_clock::now();
  GlobalBaResult result;
  if (map == nullptr) {
    result.message = "no map";
    return result;
  }
  const LocalBaProblem problem = prepare(*map, pinhole, extra_fixed);
  if (!problem.message.empty()) {
    result.message = problem.message;
    return result;
  }
  result = apply(solve(problem), map);
  result.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

LocalBaProblem GlobalBundleAdjuster::prepare(const TrackerMap& map, const Pinhole& pinhole,
                                             const std::set<std::int64_t>& extra_fixed) const {
  LocalBaProblem problem;
  problem.pinhole = pinhole;
  if (map.keyframes().size() < 2) {
    problem.message = "fewer than two keyframes";
    return problem;
  }
  problem.newest_keyframe_id = map.keyframes().rbegin()->first;
  const std::int64_t oldest_id = map.keyframes().begin()->first;
  std::set<std::int64_t> point_ids;
  for (const auto& [id, keyframe] : map.keyframes()) {
    problem.T_world_keyframe[id] = keyframe.T_world_camera;
    problem.fixed[id] = id == oldest_id || extra_fixed.count(id) > 0;
    for (std::int64_t point_id : keyframe.map_point_ids) {
      if (point_id >= 0 && map.point(point_id) != nullptr) point_ids.insert(point_id);
    }
  }
  // A point seen by one keyframe only fits its observation exactly wherever the keyframe is: it
  // adds nothing to the poses and moves with its keyframe (addBaPoints, solveBundleAdjustment).
  addBaPoints(map, point_ids, &problem);
  if (problem.p_world_m.empty()) {
    problem.message = "no map point seen by two keyframes";
    return problem;
  }
  addBaObservations(map, options_, &problem);
  addKeyframePairPriors(map, options_, extra_fixed, &problem);
  return problem;
}

LocalBaSolution GlobalBundleAdjuster::solve(const LocalBaProblem& problem) const {
  BaSolverSettings settings;
  settings.iterations = options_.global_ba_iterations;
  settings.sparse = true;
  settings.max_seconds_per_round = options_.global_ba_max_seconds / 2.0;
  return solveBundleAdjustment(problem, options_, settings);
}

GlobalBaResult GlobalBundleAdjuster::apply(const LocalBaSolution& solution, TrackerMap* map) const {
  const LocalBaResult applied = applyBundleAdjustment(solution, map);
  GlobalBaResult result;
  result.single_view_points = applied.single_view_points;
  result.ran = applied.ran;
  result.keyframes = applied.optimized_keyframes + applied.fixed_keyframes;
  result.fixed_keyframes = applied.fixed_keyframes;
  result.points = applied.points;
  result.observations = applied.observations;
  result.removed_observations = applied.removed_observations;
  result.message = applied.message;
  return result;
}

std::string describe(const GlobalBaResult& result) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(1);
  if (!result.ran) {
    os << "not run (" << result.message << ")";
  } else {
    os << result.time_ms << " ms (" << result.keyframes << " keyframes, " << result.points << " points (+"
       << result.single_view_points << " seen once, moved with their keyframe), " << result.observations
       << " observations, " << result.removed_observations << " outliers removed)";
  }
  return os.str();
}

std::string describeAfterLoop(const GlobalBaStats& stats) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(1) << stats.after_loop_runs << " runs";
  if (stats.after_loop_runs > 0) {
    os << ", " << stats.after_loop_total_ms / stats.after_loop_runs << " ms mean, " << stats.after_loop_max_ms
       << " ms max";
  }
  return os.str();
}

}  // namespace tracking
}  // namespace dypho
