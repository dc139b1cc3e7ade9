#include "dypho/tracking/loop_closer.h"

#include <map>

namespace dypho {
namespace tracking {

LoopCloser::LoopCloser(const TrackingOptions& options) : options_(options), optimizer_(options) { options_.validate(); }

LoopCorrection LoopCloser::close(TrackerMap* map, const LoopResult& loop,
                                 std::int64_t unanchored_from_keyframe_id) const {
  LoopCorrection out;
  if (map == nullptr || !loop.found || map->keyframe(loop.current_keyframe_id) == nullptr ||
      map->keyframe(loop.loop_keyframe_id) == nullptr) {
    out.message = "no verified loop";
    return out;
  }
  std::map<std::int64_t, Eigen::Isometry3d> poses;
  for (const auto& kv : map->keyframes()) poses[kv.first] = kv.second.T_world_camera;
  std::vector<PoseGraphEdge> edges;
  const auto relative = [&](std::int64_t a, std::int64_t b) {
    return PoseGraphEdge{a, b, poses[a].inverse() * poses[b], 1.0};
  };
  // The segment's start is a guess: with a loop across it, no edge ties the segment to the guess.
  const std::int64_t guessed_start = unanchored_from_keyframe_id >= 0 &&
                                             loop.loop_keyframe_id < unanchored_from_keyframe_id &&
                                             loop.current_keyframe_id >= unanchored_from_keyframe_id
                                         ? unanchored_from_keyframe_id
                                         : -1;
  std::int64_t previous = -1;
  for (const auto& kv : poses) {
    const bool across_guess = guessed_start >= 0 && previous < guessed_start && kv.first >= guessed_start;
    if (previous >= 0 && !across_guess) edges.push_back(relative(previous, kv.first));
    for (std::int64_t other : map->covisibleKeyframes(kv.first, 100)) {
      if (other >= kv.first || (other == previous && !across_guess)) continue;  // each pair once
      if (map->sharedPoints(kv.first, other) < options_.pose_graph_min_shared) continue;
      edges.push_back(relative(other, kv.first));
    }
    previous = kv.first;
  }
  edges.push_back({loop.loop_keyframe_id, loop.current_keyframe_id,
                   poses[loop.loop_keyframe_id].inverse() * loop.T_world_current, options_.loop_edge_weight});
  const PoseGraphResult graph = optimizer_.optimize(poses, edges, loop.loop_keyframe_id);
  if (!graph.success) {
    out.message = "pose graph failed: " + graph.message;
    return out;
  }
  for (const auto& kv : graph.T_world_keyframe) {
    const Eigen::Isometry3d delta = poses[kv.first].inverse() * kv.second;
    if (delta.translation().norm() > 1e-3 || Eigen::AngleAxisd(delta.rotation()).angle() > 0.01 * M_PI / 180.0) {
      out.corrected_keyframes.emplace_back(kv.first, kv.second);
    }
  }
  out.T_correction = graph.T_world_keyframe.at(loop.current_keyframe_id) * poses[loop.current_keyframe_id].inverse();
  map->applyKeyframePoses(graph.T_world_keyframe);
  for (const auto& m : loop.point_matches) {
    if (map->mergePoints(m.first, m.second)) ++out.fused_points;
  }
  out.applied = true;
  return out;
}

}  // namespace tracking
}  // namespace dypho
