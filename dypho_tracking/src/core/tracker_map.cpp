#include "dypho/tracking/tracker_map.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <unordered_set>

namespace dypho {
namespace tracking {
namespace {

/// Frames a point must have been predicted visible in before culling judges it [count].
constexpr int kCullMinVisible = 10;
/// Other keyframes that must see a point for it to count as redundant (ORB-SLAM's rule) [count].
constexpr int kRedundantObservers = 3;

}  // namespace

TrackerMap::TrackerMap(const TrackingOptions& options) : options_(options) { options_.validate(); }

void TrackerMap::clear() {
  keyframes_.clear();
  points_.clear();
  removed_.clear();
}

std::vector<std::int64_t> TrackerMap::addKeyframe(MapKeyframe kf) {
  const size_t n = kf.features.size();
  kf.map_point_ids.resize(n, -1);
  for (size_t i = 0; i < n; ++i) {
    std::int64_t& id = kf.map_point_ids[i];
    auto it = id >= 0 ? points_.find(id) : points_.end();
    if (it != points_.end() && it->second.observations.count(kf.id) == 0) {
      it->second.observations[kf.id] = static_cast<int>(i);
      continue;
    }
    if (it != points_.end()) id = -1;  // already observed by this keyframe: a second point
    if (id < 0) id = next_point_id_;
    next_point_id_ = std::max(next_point_id_, id + 1);
    MapPoint p;
    p.id = id;
    p.p_world_m = kf.T_world_camera * kf.features.p_camera_m[i];
    p.descriptor = kf.features.descriptors.row(static_cast<int>(i)).clone();
    p.keypoint = kf.features.keypoints[i];
    p.reference_distance_m = kf.features.p_camera_m[i].norm();
    p.first_keyframe_id = kf.id;
    p.observations[kf.id] = static_cast<int>(i);
    points_[id] = std::move(p);
  }
  std::vector<std::int64_t> ids = kf.map_point_ids;
  keyframes_[kf.id] = std::move(kf);
  return ids;
}

int TrackerMap::sharedPoints(std::int64_t a, std::int64_t b) const {
  const MapKeyframe* ka = keyframe(a);
  if (ka == nullptr || keyframe(b) == nullptr) return 0;
  int count = 0;
  for (std::int64_t id : ka->map_point_ids) {
    const MapPoint* p = point(id);
    if (p != nullptr && p->observations.count(b) > 0) ++count;
  }
  return count;
}

std::vector<std::int64_t> TrackerMap::covisibleKeyframes(std::int64_t keyframe_id, int max_count) const {
  const MapKeyframe* kf = keyframe(keyframe_id);
  std::vector<std::int64_t> out;
  if (kf == nullptr || max_count <= 0) return out;
  std::unordered_map<std::int64_t, int> weights;
  for (std::int64_t id : kf->map_point_ids) {
    const MapPoint* p = point(id);
    if (p == nullptr) continue;
    for (const auto& obs : p->observations) {
      if (obs.first != keyframe_id) ++weights[obs.first];
    }
  }
  std::vector<std::pair<int, std::int64_t>> sorted;
  for (const auto& w : weights) {
    if (w.second >= options_.covisibility_min_shared) sorted.emplace_back(w.second, w.first);
  }
  // Most shared first; ties: the newer keyframe first (deterministic order).
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second > b.second; });
  for (size_t i = 0; i < sorted.size() && static_cast<int>(i) < max_count; ++i) {
    out.push_back(sorted[i].second);
  }
  return out;
}

KeyframePoints TrackerMap::keyframePoints(std::int64_t keyframe_id) const {
  return collectPoints(keyframe_id, {keyframe_id});
}

std::vector<std::int64_t> TrackerMap::localKeyframes(std::int64_t keyframe_id) const {
  std::vector<std::int64_t> kfs{keyframe_id};
  for (std::int64_t id : covisibleKeyframes(keyframe_id, options_.local_map_keyframes)) kfs.push_back(id);
  return kfs;
}

KeyframePoints TrackerMap::localPoints(std::int64_t keyframe_id) const {
  return collectPoints(keyframe_id, localKeyframes(keyframe_id));
}

std::vector<std::int64_t> TrackerMap::nearbyKeyframes(std::int64_t keyframe_id,
                                                      const std::vector<std::int64_t>& exclude,
                                                      std::int64_t min_id) const {
  std::vector<std::int64_t> out;
  const MapKeyframe* reference = keyframe(keyframe_id);
  if (reference == nullptr || options_.local_map_nearby_keyframes <= 0) return out;
  const Eigen::Vector3d axis = reference->T_world_camera.linear().col(2);
  const Eigen::Vector3d centre_m = reference->T_world_camera.translation();
  const std::unordered_set<std::int64_t> excluded(exclude.begin(), exclude.end());
  std::vector<std::pair<double, std::int64_t>> near;  // (closeness, id); keyframes_ is ordered by id
  for (const auto& [id, kf] : keyframes_) {
    if (id < min_id || id == keyframe_id || excluded.count(id) > 0) continue;
    const double distance_m = (kf.T_world_camera.translation() - centre_m).norm();
    const double cosine = std::clamp(axis.dot(kf.T_world_camera.linear().col(2)), -1.0, 1.0);
    const double angle_deg = std::acos(cosine) * 180.0 / M_PI;
    if (distance_m < options_.local_map_nearby_max_distance_m && angle_deg < options_.local_map_nearby_max_angle_deg) {
      near.emplace_back(angle_deg + 100.0 * distance_m, id);
    }
  }
  std::stable_sort(near.begin(), near.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t i = 0; i < near.size() && static_cast<int>(i) < options_.local_map_nearby_keyframes; ++i) {
    out.push_back(near[i].second);
  }
  return out;
}

KeyframePoints TrackerMap::trackingPoints(std::int64_t keyframe_id, std::int64_t min_nearby_id) const {
  std::vector<std::int64_t> kfs = localKeyframes(keyframe_id);
  for (std::int64_t id : nearbyKeyframes(keyframe_id, kfs, min_nearby_id)) kfs.push_back(id);
  return collectPoints(keyframe_id, kfs);
}

KeyframePoints TrackerMap::collectPoints(std::int64_t keyframe_id, const std::vector<std::int64_t>& kfs) const {
  KeyframePoints out;
  const MapKeyframe* kf = keyframe(keyframe_id);
  if (kf == nullptr) return out;
  std::unordered_set<std::int64_t> seen;
  std::vector<const MapPoint*> selected;
  for (std::int64_t k : kfs) {
    for (std::int64_t id : keyframes_.at(k).map_point_ids) {
      const MapPoint* p = point(id);
      if (p == nullptr || !seen.insert(id).second) continue;
      selected.push_back(p);
    }
  }
  out.p_world_m.reserve(selected.size());
  out.keypoints.reserve(selected.size());
  out.map_point_ids.reserve(selected.size());
  out.reference_distance_m.reserve(selected.size());
  out.descriptors.create(static_cast<int>(selected.size()), 32, CV_8UC1);
  if (options_.point_probation_frames > 0) out.verified.reserve(selected.size());
  for (size_t i = 0; i < selected.size(); ++i) {
    const MapPoint& p = *selected[i];
    out.p_world_m.push_back(p.p_world_m);
    out.keypoints.push_back(p.keypoint);
    out.map_point_ids.push_back(p.id);
    out.reference_distance_m.push_back(p.reference_distance_m);
    p.descriptor.copyTo(out.descriptors.row(static_cast<int>(i)));
    if (options_.point_probation_frames > 0) {
      out.verified.push_back(p.num_confirmed >= options_.point_probation_frames ? 1 : 0);
    }
  }
  return out;
}

void TrackerMap::updateVisibility(const std::vector<std::int64_t>& visible, const std::vector<std::int64_t>& found) {
  for (std::int64_t id : visible) {
    auto it = points_.find(id);
    if (it != points_.end()) ++it->second.num_visible;
  }
  for (std::int64_t id : found) {
    auto it = points_.find(id);
    if (it != points_.end()) ++it->second.num_found;
  }
}

void TrackerMap::detachObservations(const MapPoint& p) {
  for (const auto& obs : p.observations) {
    auto kf = keyframes_.find(obs.first);
    if (kf != keyframes_.end() && obs.second < static_cast<int>(kf->second.map_point_ids.size())) {
      kf->second.map_point_ids[static_cast<size_t>(obs.second)] = -1;
    }
  }
}

int TrackerMap::cullPoints() {
  int removed = 0;
  for (auto it = points_.begin(); it != points_.end();) {
    const MapPoint& p = it->second;
    const bool bad = p.num_visible >= kCullMinVisible && p.num_found < options_.cull_min_found_ratio * p.num_visible;
    if (!bad) {
      ++it;
      continue;
    }
    detachObservations(p);
    it = points_.erase(it);
    ++removed;
  }
  return removed;
}

std::vector<std::int64_t> TrackerMap::cullMovingPoints(const std::vector<std::int64_t>& on_dynamic, int min_hits,
                                                       bool camera_still, bool still_only) {
  std::vector<std::int64_t> removed;
  for (std::int64_t id : on_dynamic) {
    auto it = points_.find(id);
    if (it == points_.end()) continue;
    MapPoint& p = it->second;
    ++p.num_on_dynamic;
    if (camera_still) ++p.num_on_dynamic_still;
    const int hits = still_only ? p.num_on_dynamic_still : p.num_on_dynamic;
    if (min_hits <= 0 || hits < min_hits || hits < p.num_found) continue;
    detachObservations(p);
    points_.erase(it);
    removed.push_back(id);
  }
  return removed;
}

std::vector<std::int64_t> TrackerMap::updateProbation(const std::vector<std::int64_t>& confirmed,
                                                      const std::vector<std::int64_t>& refuted) {
  for (std::int64_t id : confirmed) {
    auto it = points_.find(id);
    if (it != points_.end()) ++it->second.num_confirmed;
  }
  std::vector<std::int64_t> removed;
  for (std::int64_t id : refuted) {
    auto it = points_.find(id);
    if (it == points_.end()) continue;
    MapPoint& p = it->second;
    ++p.num_refuted;
    if (p.num_confirmed >= options_.point_probation_frames || p.num_refuted < options_.point_probation_max_refuted)
      continue;
    detachObservations(p);
    points_.erase(it);
    removed.push_back(id);
  }
  return removed;
}

bool TrackerMap::isVerified(std::int64_t point_id) const {
  const MapPoint* p = point(point_id);
  return p != nullptr && p->num_confirmed >= options_.point_probation_frames;
}

std::vector<std::int64_t> TrackerMap::removePointsCreatedBy(std::int64_t keyframe_id,
                                                            const std::vector<std::int64_t>& ids, int min_hits) {
  std::vector<std::int64_t> removed;
  for (std::int64_t id : ids) {
    auto it = points_.find(id);
    if (it == points_.end() || it->second.first_keyframe_id != keyframe_id || it->second.num_on_dynamic < min_hits)
      continue;
    detachObservations(it->second);
    points_.erase(it);
    removed.push_back(id);
  }
  return removed;
}

bool TrackerMap::isRedundant(std::int64_t keyframe_id, double redundant_ratio) const {
  const MapKeyframe* kf = keyframe(keyframe_id);
  if (kf == nullptr) return false;
  int points = 0, redundant = 0;
  for (size_t i = 0; i < kf->map_point_ids.size(); ++i) {
    const MapPoint* p = point(kf->map_point_ids[i]);
    if (p == nullptr) continue;
    ++points;
    const int octave = kf->features.keypoints[i].octave;
    int observers = 0;
    for (const auto& [other_id, index] : p->observations) {
      if (other_id == keyframe_id) continue;
      const MapKeyframe& other = keyframes_.at(other_id);
      if (other.features.keypoints[static_cast<size_t>(index)].octave <= octave + 1 &&
          ++observers >= kRedundantObservers) {
        ++redundant;
        break;
      }
    }
  }
  return points > 0 && redundant >= redundant_ratio * points;
}

bool TrackerMap::removeKeyframe(std::int64_t keyframe_id) {
  auto it = keyframes_.find(keyframe_id);
  if (it == keyframes_.end() || keyframes_.size() < 2) return false;
  const std::vector<std::int64_t> covisible = covisibleKeyframes(keyframe_id, 1);
  const std::int64_t parent_id =
      !covisible.empty() ? covisible.front()
                         : (keyframes_.rbegin()->first != keyframe_id ? keyframes_.rbegin()->first
                                                                      : std::next(keyframes_.rbegin())->first);
  const MapKeyframe& parent = keyframes_.at(parent_id);
  RemovedKeyframe entry{parent_id, parent.T_world_camera.inverse() * it->second.T_world_camera};
  // Keyframes removed earlier and attached to this one move to its parent: chains stay one long.
  for (auto& [id, removed] : removed_) {
    if (removed.parent_id != keyframe_id) continue;
    removed.parent_id = parent_id;
    removed.T_parent_keyframe = entry.T_parent_keyframe * removed.T_parent_keyframe;
  }
  removed_[keyframe_id] = entry;
  for (std::int64_t id : it->second.map_point_ids) {
    auto p = id >= 0 ? points_.find(id) : points_.end();
    if (p == points_.end()) continue;
    p->second.observations.erase(keyframe_id);
    if (p->second.observations.empty()) {
      points_.erase(p);
    } else if (p->second.first_keyframe_id == keyframe_id) {
      p->second.first_keyframe_id = p->second.observations.begin()->first;
    }
  }
  keyframes_.erase(it);
  return true;
}

std::optional<Eigen::Isometry3d> TrackerMap::keyframePose(std::int64_t keyframe_id) const {
  if (const MapKeyframe* kf = keyframe(keyframe_id)) return kf->T_world_camera;
  auto removed = removed_.find(keyframe_id);
  if (removed == removed_.end()) return std::nullopt;
  const MapKeyframe* parent = keyframe(removed->second.parent_id);
  if (parent == nullptr) return std::nullopt;
  return parent->T_world_camera * removed->second.T_parent_keyframe;
}

bool TrackerMap::mergePoints(std::int64_t keep_id, std::int64_t remove_id) {
  if (keep_id == remove_id) return false;
  MapPoint* keep = mutablePoint(keep_id);
  auto remove = points_.find(remove_id);
  if (keep == nullptr || remove == points_.end()) return false;
  for (const auto& obs : remove->second.observations) {
    auto kf = keyframes_.find(obs.first);
    if (kf == keyframes_.end()) continue;
    auto& ids = kf->second.map_point_ids;
    if (obs.second >= static_cast<int>(ids.size())) continue;
    if (keep->observations.count(obs.first) == 0) {
      keep->observations[obs.first] = obs.second;
      ids[static_cast<size_t>(obs.second)] = keep_id;
    } else {
      ids[static_cast<size_t>(obs.second)] = -1;
    }
  }
  keep->num_visible += remove->second.num_visible;
  keep->num_found += remove->second.num_found;
  points_.erase(remove);
  return true;
}

bool TrackerMap::addObservation(std::int64_t point_id, std::int64_t keyframe_id, int feature_index) {
  MapPoint* p = mutablePoint(point_id);
  MapKeyframe* kf = mutableKeyframe(keyframe_id);
  if (p == nullptr || kf == nullptr || feature_index < 0 ||
      feature_index >= static_cast<int>(kf->map_point_ids.size()) || p->observations.count(keyframe_id) > 0) {
    return false;
  }
  std::int64_t& slot = kf->map_point_ids[static_cast<std::size_t>(feature_index)];
  if (point(slot) != nullptr) return false;
  slot = point_id;
  p->observations[keyframe_id] = feature_index;
  return true;
}

void TrackerMap::applyKeyframePoses(const std::map<std::int64_t, Eigen::Isometry3d>& T_world_keyframe) {
  std::unordered_map<std::int64_t, Eigen::Isometry3d> correction;
  for (const auto& kv : T_world_keyframe) {
    auto kf = keyframes_.find(kv.first);
    if (kf == keyframes_.end()) continue;
    correction[kv.first] = kv.second * kf->second.T_world_camera.inverse();
    kf->second.T_world_camera = kv.second;
  }
  for (auto& kv : points_) {
    auto c = correction.find(kv.second.first_keyframe_id);
    if (c != correction.end()) kv.second.p_world_m = c->second * kv.second.p_world_m;
  }
}

const MapKeyframe* TrackerMap::keyframe(std::int64_t id) const {
  auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}

const MapPoint* TrackerMap::point(std::int64_t id) const {
  if (id < 0) return nullptr;
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

MapKeyframe* TrackerMap::mutableKeyframe(std::int64_t id) {
  auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}

MapPoint* TrackerMap::mutablePoint(std::int64_t id) {
  if (id < 0) return nullptr;
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

}  // namespace tracking
}  // namespace dypho
