#include "dypho/tracking/local_bundle_adjuster.h"

#include <algorithm>
#include <map>
#include <set>
#include <vector>

#include "bundle_adjustment.h"

namespace dypho {
namespace tracking {

LocalBundleAdjuster::LocalBundleAdjuster(const TrackingOptions& options) : options_(options) { options_.validate(); }

LocalBaResult LocalBundleAdjuster::adjust(TrackerMap* map, std::int64_t newest_keyframe_id,
                                          const Pinhole& pinhole) const {
  if (map == nullptr) {
    LocalBaResult result;
    result.message = "unknown keyframe";
    return result;
  }
  return apply(solve(prepare(*map, newest_keyframe_id, pinhole)), map);
}

LocalBaProblem LocalBundleAdjuster::prepare(const TrackerMap& map, std::int64_t newest_keyframe_id,
                                            const Pinhole& pinhole) const {
  LocalBaProblem problem;
  problem.newest_keyframe_id = newest_keyframe_id;
  problem.pinhole = pinhole;
  if (options_.local_ba_keyframes <= 0) {
    problem.message = "local BA disabled (local_ba_keyframes = 0)";
    return problem;
  }
  if (map.keyframe(newest_keyframe_id) == nullptr) {
    problem.message = "unknown keyframe";
    return problem;
  }
  // Window and points.
  std::vector<std::int64_t> free_ids{newest_keyframe_id};
  for (std::int64_t id : map.covisibleKeyframes(newest_keyframe_id, options_.local_ba_keyframes - 1)) {
    free_ids.push_back(id);
  }
  if (free_ids.size() < 2) {
    problem.message = "no covisible keyframe yet";
    return problem;
  }
  std::set<std::int64_t> point_ids;
  for (std::int64_t k : free_ids) {
    for (std::int64_t id : map.keyframe(k)->map_point_ids) {
      if (map.point(id) != nullptr) point_ids.insert(id);
    }
  }
  const std::set<std::int64_t> free_set(free_ids.begin(), free_ids.end());
  std::map<std::int64_t, int> fixed_weight;  // keyframes outside the window seeing the points
  for (std::int64_t id : point_ids) {
    for (const auto& obs : map.point(id)->observations) {
      if (free_set.count(obs.first) == 0) ++fixed_weight[obs.first];
    }
  }
  std::vector<std::pair<int, std::int64_t>> fixed_sorted;
  for (const auto& kv : fixed_weight) fixed_sorted.emplace_back(kv.second, kv.first);
  std::sort(fixed_sorted.rbegin(), fixed_sorted.rend());
  if (static_cast<int>(fixed_sorted.size()) > options_.local_ba_max_fixed_keyframes) {
    fixed_sorted.resize(static_cast<size_t>(options_.local_ba_max_fixed_keyframes));
  }
  for (std::int64_t id : free_ids) {
    problem.T_world_keyframe[id] = map.keyframe(id)->T_world_camera;
    problem.fixed[id] = false;
  }
  for (const auto& f : fixed_sorted) {
    problem.T_world_keyframe[f.second] = map.keyframe(f.second)->T_world_camera;
    problem.fixed[f.second] = true;
  }
  if (fixed_sorted.empty()) problem.fixed.begin()->second = true;  // oldest of the window: gauge
  addBaPoints(map, point_ids, &problem);
  addBaObservations(map, options_, &problem);
  return problem;
}

LocalBaSolution LocalBundleAdjuster::solve(const LocalBaProblem& input) const {
  BaSolverSettings settings;
  settings.iterations = options_.local_ba_iterations;
  return solveBundleAdjustment(input, options_, settings);
}

LocalBaResult LocalBundleAdjuster::apply(const LocalBaSolution& solution, TrackerMap* map) const {
  return applyBundleAdjustment(solution, map);
}

}  // namespace tracking
}  // namespace dypho
