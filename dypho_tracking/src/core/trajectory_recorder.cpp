#include "dypho/tracking/trajectory_recorder.h"

#include <cmath>

namespace dypho {
namespace tracking {

void TrajectoryRecorder::add(const TrackingResult& result) {
  if (result.state == TrackingState::kNotInitialized) return;  // no world yet: no pose
  RecordedPose r;
  r.stamp_ns = result.stamp_ns;
  r.reference_keyframe_id = result.state == TrackingState::kOk ? result.reference_keyframe_id : std::int64_t{-1};
  r.T_reference_camera = result.T_reference_camera;
  r.T_world_camera_online = result.T_world_camera;
  r.discontinuous = result.discontinuous;
  records_.push_back(r);
}

void smoothPositions(double half_window_s, const std::vector<int>& segment_ids,
                     std::vector<std::pair<Timestamp, Eigen::Isometry3d>>* poses) {
  if (!(half_window_s > 0.0) || poses->size() != segment_ids.size()) return;
  const std::vector<std::pair<Timestamp, Eigen::Isometry3d>> raw = *poses;
  const auto seconds = [&](std::size_t j, std::size_t k) {
    return 1e-9 * static_cast<double>(raw[j].first - raw[k].first);
  };
  const auto inWindow = [&](std::size_t j, std::size_t k) {
    return segment_ids[j] == segment_ids[k] && std::abs(seconds(j, k)) <= half_window_s;
  };
  for (std::size_t k = 0; k < raw.size(); ++k) {
    if (segment_ids[k] < 0) continue;
    std::size_t first = k, last = k;  // a segment's poses are consecutive
    while (first > 0 && inWindow(first - 1, k)) --first;
    while (last + 1 < raw.size() && inWindow(last + 1, k)) ++last;
    // Least squares of p(t) = a + b t (t relative to pose k) over the window: a is the position.
    double n = 0.0, sum_t = 0.0, sum_tt = 0.0;
    Eigen::Vector3d sum_p = Eigen::Vector3d::Zero(), sum_tp = Eigen::Vector3d::Zero();
    for (std::size_t j = first; j <= last; ++j) {
      const double t = seconds(j, k);
      n += 1.0;
      sum_t += t;
      sum_tt += t * t;
      sum_p += raw[j].second.translation();
      sum_tp += t * raw[j].second.translation();
    }
    const double det = n * sum_tt - sum_t * sum_t;
    if (n < 3.0 || !(det > 1e-12 * n * n)) continue;
    (*poses)[k].second.translation() = (sum_tt * sum_p - sum_t * sum_tp) / det;
  }
}

std::vector<std::pair<Timestamp, Eigen::Isometry3d>> TrajectoryRecorder::finalPoses(
    const TrackerMap& map, double smoothing_half_window_s) const {
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> out;
  std::vector<int> segment_ids;
  out.reserve(records_.size());
  segment_ids.reserve(records_.size());
  int segment = 0;
  for (const RecordedPose& r : records_) {
    const std::optional<Eigen::Isometry3d> T_world_reference =
        r.reference_keyframe_id >= 0 ? map.keyframePose(r.reference_keyframe_id) : std::nullopt;
    out.emplace_back(r.stamp_ns,
                     T_world_reference ? *T_world_reference * r.T_reference_camera : r.T_world_camera_online);
    if (r.discontinuous) ++segment;
    if (T_world_reference) {
      segment_ids.push_back(segment);
    } else {  // lost or from a forgotten world: kept as it is, and the motion after it is another
      segment_ids.push_back(-1);
      ++segment;
    }
  }
  smoothPositions(smoothing_half_window_s, segment_ids, &out);
  return out;
}

std::vector<std::pair<Timestamp, Eigen::Isometry3d>> TrajectoryRecorder::onlinePoses() const {
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> out;
  out.reserve(records_.size());
  for (const RecordedPose& r : records_) out.emplace_back(r.stamp_ns, r.T_world_camera_online);
  return out;
}

}  // namespace tracking
}  // namespace dypho
