#include "dypho/tracking/trajectory_recorder.h"

namespace dypho {
namespace tracking {

void TrajectoryRecorder::add(const TrackingResult& result) {
  if (result.state == TrackingState::kNotInitialized) return;  // no world yet: no pose
  RecordedPose r;
  r.stamp_ns = result.stamp_ns;
  r.reference_keyframe_id = result.state == TrackingState::kOk ? result.reference_keyframe_id : std::int64_t{-1};
  r.T_reference_camera = result.T_reference_camera;
  r.T_world_camera_online = result.T_world_camera;
  records_.push_back(r);
}

std::vector<std::pair<Timestamp, Eigen::Isometry3d>> TrajectoryRecorder::finalPoses(const TrackerMap& map) const {
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> out;
  out.reserve(records_.size());
  for (const RecordedPose& r : records_) {
    const std::optional<Eigen::Isometry3d> T_world_reference =
        r.reference_keyframe_id >= 0 ? map.keyframePose(r.reference_keyframe_id) : std::nullopt;
    out.emplace_back(r.stamp_ns,
                     T_world_reference ? *T_world_reference * r.T_reference_camera : r.T_world_camera_online);
  }
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
