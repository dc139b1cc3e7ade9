#include "dypho/tracking/relocalizer.h"

#include <vector>

namespace dypho {
namespace tracking {

Relocalizer::Relocalizer(const TrackingOptions& options) : options_(options), aligner_(options) { options_.validate(); }

RelocalizationResult Relocalizer::relocalize(const TrackerMap& map, const FrameFeatures& frame, const Pinhole& pinhole,
                                             TrackingTimesMs* times, bool most_inliers) const {
  RelocalizationResult result;
  std::vector<std::int64_t> ids;
  for (auto it = map.keyframes().rbegin(); it != map.keyframes().rend(); ++it) {
    ids.push_back(it->first);
  }
  const size_t cap = static_cast<size_t>(options_.relocalization_max_keyframes);
  if (ids.size() > cap) {  // newest first, then evenly spread over the rest
    std::vector<std::int64_t> picked;
    const double step = static_cast<double>(ids.size()) / static_cast<double>(cap);
    for (size_t k = 0; k < cap; ++k) picked.push_back(ids[static_cast<size_t>(k * step)]);
    ids = picked;
  }
  if (ids.empty()) {
    result.message = "relocalisation: the map has no keyframe";
    return result;
  }
  int best_inliers = 0;
  for (std::int64_t id : ids) {
    ++result.tried;
    const MapKeyframe* kf = map.keyframe(id);
    const KeyframePoints own = map.keyframePoints(id);
    if (static_cast<int>(own.size()) < options_.relocalization_min_inliers) continue;
    AlignmentResult a = aligner_.align(own, frame, pinhole, kf->T_world_camera.inverse(), times, nullptr);
    if (!a.success) continue;
    best_inliers = std::max(best_inliers, a.num_inliers);
    if (a.num_inliers < options_.relocalization_min_inliers) continue;
    const KeyframePoints local = map.localPoints(id);
    AlignmentResult b = aligner_.align(local, frame, pinhole, a.T_camera_world, times, nullptr);
    const AlignmentResult& best = (b.success && b.num_inliers >= a.num_inliers) ? b : a;
    const Eigen::Isometry3d T_world_camera = best.T_camera_world.inverse();
    if (!T_world_camera.matrix().allFinite() || best.num_inliers <= result.num_inliers) continue;
    result.success = true;
    result.keyframe_id = id;
    result.T_world_camera = T_world_camera;
    result.num_inliers = best.num_inliers;
    if (!most_inliers) return result;
  }
  if (result.success) return result;
  result.message = "relocalisation failed against " + std::to_string(result.tried) + " keyframes (best " +
                   std::to_string(best_inliers) + " inliers, need " +
                   std::to_string(options_.relocalization_min_inliers) + ")";
  return result;
}

}  // namespace tracking
}  // namespace dypho
