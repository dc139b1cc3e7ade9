/// TrackerMap as a whole: its state for a session file, the restore from one, and the check that a
/// state read from a file can be a map.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "dypho/tracking/tracker_map.h"

namespace dypho {
namespace tracking {
namespace {

bool finiteKeypoint(const cv::KeyPoint& k) {
  return std::isfinite(k.pt.x) && std::isfinite(k.pt.y) && std::isfinite(k.size) && std::isfinite(k.angle) &&
         std::isfinite(k.response);
}

/// `rows` ORB descriptors of 32 bytes (CV_8UC1); no rows: an empty matrix too.
bool descriptorShape(const cv::Mat& descriptors, std::size_t rows) {
  if (rows == 0 && descriptors.empty()) return true;
  return descriptors.type() == CV_8UC1 && descriptors.cols == 32 && static_cast<std::size_t>(descriptors.rows) == rows;
}

std::string featuresProblem(const FrameFeatures& f) {
  const std::size_t n = f.size();
  if (f.uv_undistorted_px.size() != n || f.depth_m.size() != n || f.p_camera_m.size() != n) {
    return "its feature arrays differ in length";
  }
  if (!descriptorShape(f.descriptors, n)) return "its descriptors are not " + std::to_string(n) + " x 32 bytes";
  for (std::size_t i = 0; i < n; ++i) {
    if (!finiteKeypoint(f.keypoints[i]) || !f.uv_undistorted_px[i].allFinite() || !std::isfinite(f.depth_m[i]) ||
        !f.p_camera_m[i].allFinite()) {
      return "feature " + std::to_string(i) + " has a non-finite number";
    }
  }
  return "";
}

std::string keyframeProblem(std::int64_t key, const MapKeyframe& keyframe, std::int64_t next_point_id) {
  const std::string name = "keyframe " + std::to_string(key) + ": ";
  if (keyframe.id != key || key < 0) return name + "has the id " + std::to_string(keyframe.id);
  if (!isRigidPose(keyframe.T_world_camera)) return name + "its pose is not a rigid transform";
  if (!keyframe.blur_rates.omega_rad_s.allFinite() || !keyframe.blur_rates.velocity_m_s.allFinite() ||
      !std::isfinite(keyframe.blur_exposure_s) || keyframe.blur_exposure_s < 0.0) {
    return name + "its motion blur is not finite (velocities) or not a non-negative exposure";
  }
  const std::string features = featuresProblem(keyframe.features);
  if (!features.empty()) return name + features;
  if (keyframe.map_point_ids.size() != keyframe.features.size()) {
    return name + std::to_string(keyframe.map_point_ids.size()) + " map-point ids for " +
           std::to_string(keyframe.features.size()) + " features";
  }
  for (std::int64_t id : keyframe.map_point_ids) {
    if (id < -1 || id >= next_point_id) {
      return name + "map-point id " + std::to_string(id) + " is outside [-1, " + std::to_string(next_point_id) + ")";
    }
  }
  return "";
}

std::string pointProblem(std::int64_t key, const MapPoint& point, const TrackerMapState& state) {
  const std::string name = "map point " + std::to_string(key) + ": ";
  if (point.id != key || key < 0 || key >= state.next_point_id) {
    return name + "has the id " + std::to_string(point.id) + " (ids are in [0, " + std::to_string(state.next_point_id) +
           "))";
  }
  if (!point.p_world_m.allFinite() || !finiteKeypoint(point.keypoint) || !std::isfinite(point.reference_distance_m)) {
    return name + "has a non-finite number";
  }
  if (!descriptorShape(point.descriptor, 1)) return name + "its descriptor is not 32 bytes";
  for (const auto& [keyframe_id, index] : point.observations) {
    const auto keyframe = state.keyframes.find(keyframe_id);
    if (keyframe == state.keyframes.end()) return name + "observed by unknown keyframe " + std::to_string(keyframe_id);
    if (index < 0 || static_cast<std::size_t>(index) >= keyframe->second.features.size()) {
      return name + "observed as feature " + std::to_string(index) + " of keyframe " + std::to_string(keyframe_id) +
             ", which has " + std::to_string(keyframe->second.features.size());
    }
  }
  return "";
}

std::string removedProblem(std::int64_t id, const RemovedKeyframe& removed, const TrackerMapState& state) {
  const std::string name = "removed keyframe " + std::to_string(id) + ": ";
  if (id < 0 || state.keyframes.count(id) > 0) return name + "its id is negative or still in the map";
  if (!isRigidPose(removed.T_parent_keyframe)) return name + "its pose is not a rigid transform";
  return "";
}

cv::Mat deepCopy(const cv::Mat& m) { return m.empty() ? cv::Mat() : m.clone(); }

}  // namespace

bool isRigidPose(const Eigen::Isometry3d& T) {
  const Eigen::Matrix4d& m = T.matrix();
  if (!m.allFinite() || m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) return false;
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 && R.determinant() > 0;
}

std::string trackerMapStateProblem(const TrackerMapState& state) {
  if (state.next_point_id < 0) return "negative next map-point id";
  for (const auto& [id, keyframe] : state.keyframes) {
    std::string problem = keyframeProblem(id, keyframe, state.next_point_id);
    if (!problem.empty()) return problem;
  }
  for (const auto& [id, point] : state.points) {
    std::string problem = pointProblem(id, point, state);
    if (!problem.empty()) return problem;
  }
  for (const auto& [id, removed] : state.removed) {
    std::string problem = removedProblem(id, removed, state);
    if (!problem.empty()) return problem;
  }
  return "";
}

TrackerMapState TrackerMap::state() const {
  TrackerMapState state;
  // Deep copies: the state stays as it is while the map goes on.
  for (const auto& [id, keyframe] : keyframes_) {
    MapKeyframe& copy = state.keyframes[id] = keyframe;
    copy.features.descriptors = deepCopy(keyframe.features.descriptors);
  }
  for (const auto& [id, point] : points_) {
    MapPoint& copy = state.points[id] = point;
    copy.descriptor = deepCopy(point.descriptor);
  }
  state.removed.insert(removed_.begin(), removed_.end());
  state.next_point_id = next_point_id_;
  return state;
}

void TrackerMap::restore(TrackerMapState state) {
  const std::string problem = trackerMapStateProblem(state);
  if (!problem.empty()) throw std::invalid_argument("TrackerMap::restore: " + problem);
  // Fresh containers filled in id order: the same state always gives the same iteration order.
  std::unordered_map<std::int64_t, MapPoint> points;
  points.reserve(state.points.size());
  for (auto& [id, point] : state.points) points.emplace(id, std::move(point));
  std::unordered_map<std::int64_t, RemovedKeyframe> removed;
  removed.reserve(state.removed.size());
  for (const auto& [id, entry] : state.removed) removed.emplace(id, entry);
  keyframes_ = std::move(state.keyframes);
  points_ = std::move(points);
  removed_ = std::move(removed);
  next_point_id_ = std::max(next_point_id_, state.next_point_id);
}

}  // namespace tracking
}  // namespace dypho
