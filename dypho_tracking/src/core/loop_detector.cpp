#include "dypho/tracking/loop_detector.h"

#include <algorithm>
#include <cmath>

namespace dypho {
namespace tracking {

LoopDetector::LoopDetector(const TrackingOptions& options) : options_(options), aligner_(options) {
  options_.validate();
}

LoopResult LoopDetector::detect(const TrackerMap& map, std::int64_t current_id, const Pinhole& pinhole) const {
  LoopResult result;
  result.current_keyframe_id = current_id;
  const MapKeyframe* current = map.keyframe(current_id);
  if (current == nullptr) {
    result.message = "unknown keyframe";
    return result;
  }
  const Eigen::Vector3d c = current->T_world_camera.translation();
  const Eigen::Vector3d axis = current->T_world_camera.rotation().col(2);
  const double cos_max = std::cos(options_.loop_max_angle_deg * M_PI / 180.0);
  std::vector<std::pair<double, std::int64_t>> candidates;
  for (const auto& kv : map.keyframes()) {
    if (kv.first > current_id - options_.loop_min_keyframe_gap) break;  // ordered by id
    const Eigen::Isometry3d& T = kv.second.T_world_camera;
    const double distance = (T.translation() - c).norm();
    if (distance > options_.loop_search_radius_m) continue;
    if (T.rotation().col(2).dot(axis) < cos_max) continue;
    if (map.sharedPoints(current_id, kv.first) >= options_.covisibility_min_shared) continue;
    candidates.emplace_back(distance, kv.first);
  }
  std::sort(candidates.begin(), candidates.end());
  if (static_cast<int>(candidates.size()) > options_.loop_max_candidates) {
    candidates.resize(static_cast<size_t>(options_.loop_max_candidates));
  }
  if (candidates.empty()) {
    result.message = "no loop candidate";
    return result;
  }
  for (const auto& cand : candidates) {
    ++result.candidates;
    const KeyframePoints own = map.keyframePoints(cand.second);
    const KeyframePoints local = map.localPoints(cand.second);
    const AlignmentResult a =
        aligner_.align(local, current->features, pinhole, current->T_world_camera.inverse(), nullptr, &own);
    if (!a.success || a.num_inliers < options_.loop_min_inliers) continue;
    const Eigen::Isometry3d T_world_current = a.T_camera_world.inverse();
    if (!T_world_current.matrix().allFinite()) continue;
    if (a.num_inliers <= result.num_inliers) continue;
    const KeyframePoints& ref = a.matches_refer_to_fallback ? own : local;
    result.found = true;
    result.loop_keyframe_id = cand.second;
    result.T_world_current = T_world_current;
    result.num_inliers = a.num_inliers;
    result.point_matches.clear();
    for (size_t m = 0; m < a.matches.size(); ++m) {
      if (!a.inliers[m]) continue;
      const std::int64_t old_id = ref.map_point_ids[static_cast<size_t>(a.matches[m].reference_index)];
      const std::int64_t cur_id = current->map_point_ids[static_cast<size_t>(a.matches[m].frame_index)];
      if (old_id >= 0 && cur_id >= 0) result.point_matches.emplace_back(old_id, cur_id);
    }
  }
  if (!result.found) {
    result.message = "no candidate of " + std::to_string(result.candidates) + " reached " +
                     std::to_string(options_.loop_min_inliers) + " inliers";
  }
  return result;
}

}  // namespace tracking
}  // namespace dypho
