#include "dypho/tracking/keyframe_point_fuser.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>

#include "keypoint_grid.h"

namespace dypho {
namespace tracking {
namespace {

constexpr double kCellPx = 16.0;  ///< side of the feature grid's cells [px]

/// The feature of `target` that matches `point`: -1 when none passes the tests (header).
int matchInKeyframe(const MapPoint& point, const MapKeyframe& target, const Eigen::Isometry3d& T_target_world,
                    const KeypointGrid& grid, const Pinhole& pinhole, const TrackingOptions& options) {
  const Eigen::Vector3d p_camera = T_target_world * point.p_world_m;
  if (!(p_camera.z() > options.min_depth_m)) return -1;
  const Eigen::Vector2d uv = pinhole.project(p_camera);
  const int level = point.keypoint.octave;
  const double radius_px = options.fuse_radius_px * std::pow(options.scale_factor, level);
  const double max_depth_step_m = options.fuse_max_depth_ratio * p_camera.z();
  int best = -1;
  int best_distance = options.fuse_max_hamming_distance + 1;
  const FrameFeatures& features = target.features;
  grid.forEachNear(uv, radius_px, [&](int i) {
    const std::size_t f = static_cast<std::size_t>(i);
    if ((features.uv_undistorted_px[f] - uv).squaredNorm() > radius_px * radius_px) return;
    if (std::abs(features.keypoints[f].octave - level) > options.max_level_difference) return;
    if (std::abs(features.depth_m[f] - p_camera.z()) > max_depth_step_m) return;
    const int distance = static_cast<int>(cv::norm(point.descriptor, features.descriptors.row(i), cv::NORM_HAMMING));
    if (distance < best_distance) {
      best_distance = distance;
      best = i;
    }
  });
  return best;
}

/// The point's descriptor, keypoint and reference distance become those of its observation whose
/// descriptor is nearest to the others' (the least median Hamming distance: ORB-SLAM's
/// distinctive descriptor). Tracking matches the point with them; a point that gained views in
/// the fuse step would otherwise keep those of the view it was first made from.
void refreshDescriptor(TrackerMap* map, std::int64_t point_id) {
  MapPoint* point = map->mutablePoint(point_id);
  if (point == nullptr || point->observations.size() < 2) return;
  struct View {
    const MapKeyframe* keyframe;
    int feature;
  };
  std::vector<View> views;
  for (const auto& [keyframe_id, feature] : point->observations) {
    const MapKeyframe* keyframe = map->keyframe(keyframe_id);
    if (keyframe != nullptr && feature >= 0 && feature < static_cast<int>(keyframe->features.size())) {
      views.push_back({keyframe, feature});
    }
  }
  if (views.size() < 2) return;
  const std::size_t n = views.size();
  std::vector<int> distance(n * n, 0);
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      distance[a * n + b] = distance[b * n + a] =
          static_cast<int>(cv::norm(views[a].keyframe->features.descriptors.row(views[a].feature),
                                    views[b].keyframe->features.descriptors.row(views[b].feature), cv::NORM_HAMMING));
    }
  }
  std::size_t best = 0;
  int best_median = -1;
  for (std::size_t a = 0; a < n; ++a) {
    std::vector<int> row(distance.begin() + static_cast<std::ptrdiff_t>(a * n),
                         distance.begin() + static_cast<std::ptrdiff_t>((a + 1) * n));
    std::nth_element(row.begin(), row.begin() + static_cast<std::ptrdiff_t>((n - 1) / 2), row.end());
    const int median = row[(n - 1) / 2];
    if (best_median < 0 || median < best_median) {
      best_median = median;
      best = a;
    }
  }
  const View& view = views[best];
  point->descriptor = view.keyframe->features.descriptors.row(view.feature).clone();
  point->keypoint = view.keyframe->features.keypoints[static_cast<std::size_t>(view.feature)];
  point->reference_distance_m = (point->p_world_m - view.keyframe->T_world_camera.translation()).norm();
}

/// True when the point may be moved between keyframes (header): past probation and never seen
/// on a moving surface.
bool isTrusted(const TrackerMap& map, std::int64_t id) {
  const MapPoint* point = map.point(id);
  return point != nullptr && point->num_on_dynamic == 0 && map.isVerified(id);
}

/// Matches each trusted one of `point_ids` in keyframe `target_id`: merges it with the
/// feature's point (unless that one was seen on a moving surface) or adds the feature's
/// observation of it. The points that gained views go into `changed`.
void fuseInto(TrackerMap* map, const std::vector<std::int64_t>& point_ids, std::int64_t target_id,
              const Pinhole& pinhole, const TrackingOptions& options, FuseStats* stats,
              std::vector<std::int64_t>* changed) {
  const MapKeyframe* target = map->keyframe(target_id);
  if (target == nullptr) return;
  const KeypointGrid grid(target->features.uv_undistorted_px, kCellPx);
  const Eigen::Isometry3d T_target_world = target->T_world_camera.inverse();
  for (const std::int64_t id : point_ids) {
    const MapPoint* point = map->point(id);
    if (point == nullptr || point->observations.count(target_id) > 0 || !isTrusted(*map, id)) continue;
    const int feature = matchInKeyframe(*point, *target, T_target_world, grid, pinhole, options);
    if (feature < 0) continue;
    const std::int64_t other_id = target->map_point_ids[static_cast<std::size_t>(feature)];
    const MapPoint* other = map->point(other_id);
    if (other == nullptr) {
      if (map->addObservation(id, target_id, feature)) {
        ++stats->added;
        changed->push_back(id);
      }
      continue;
    }
    if (other->num_on_dynamic > 0) continue;
    // A point on probation gives way to the trusted one; else the better observed point stays
    // (the older on a tie): it has the better position.
    const bool keep_this = !map->isVerified(other_id) || point->observations.size() > other->observations.size() ||
                           (point->observations.size() == other->observations.size() && id < other_id);
    const std::int64_t keep_id = keep_this ? id : other_id;
    if (map->mergePoints(keep_id, keep_this ? other_id : id)) {
      ++stats->merged;
      changed->push_back(keep_id);
    }
  }
}

/// Ids of the points keyframe `keyframe_id` observes.
std::vector<std::int64_t> pointsOf(const TrackerMap& map, std::int64_t keyframe_id) {
  std::vector<std::int64_t> ids;
  if (const MapKeyframe* keyframe = map.keyframe(keyframe_id)) {
    for (const std::int64_t id : keyframe->map_point_ids) {
      if (map.point(id) != nullptr) ids.push_back(id);
    }
  }
  return ids;
}

}  // namespace

FuseStats fuseKeyframePoints(TrackerMap* map, std::int64_t keyframe_id, const Pinhole& pinhole,
                             const TrackingOptions& options) {
  FuseStats stats;
  if (options.fuse_keyframes <= 0 || map->keyframe(keyframe_id) == nullptr) return stats;
  std::vector<std::int64_t> changed;
  for (const std::int64_t neighbour : map->covisibleKeyframes(keyframe_id, options.fuse_keyframes)) {
    fuseInto(map, pointsOf(*map, keyframe_id), neighbour, pinhole, options, &stats, &changed);
    fuseInto(map, pointsOf(*map, neighbour), keyframe_id, pinhole, options, &stats, &changed);
  }
  std::sort(changed.begin(), changed.end());
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
  for (const std::int64_t id : changed) refreshDescriptor(map, id);
  return stats;
}

}  // namespace tracking
}  // namespace dypho
