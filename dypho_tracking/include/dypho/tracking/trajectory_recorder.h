#pragma once
/// \file trajectory_recorder.h
/// Per-frame poses kept relative to their reference keyframe, so that the saved trajectory
/// follows the keyframe corrections of local BA and loop closure made after the frame was tracked
/// (the trajectory ORB-SLAM saves). The poses published at frame time are kept as well.

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/common/types.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {

/// One recorded frame.
struct RecordedPose {
  Timestamp stamp_ns = 0;
  std::int64_t reference_keyframe_id = -1;  ///< -1: not tracked (no pose to refine)
  Eigen::Isometry3d T_reference_camera = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_camera_online = Eigen::Isometry3d::Identity();  ///< as published
};

/// Records tracked frames; `finalPoses` re-expresses them with the keyframes' current poses.
class TrajectoryRecorder {
 public:
  /// Records `result`. A lost frame keeps the pose it was published with (the last trusted one),
  /// so there is one pose per frame from the first keyframe on, as published. A frame before
  /// the first keyframe (kNotInitialized: no world yet, e.g. the unjudged first frame) has no
  /// pose and is not recorded.
  void add(const TrackingResult& result);

  /// T_world_camera of every recorded frame, in order: T_world_reference (current, from
  /// `map.keyframePose`, which also answers for removed keyframes) * T_reference_camera. A frame
  /// that was not tracked, or whose keyframe `map` no longer knows (tracker reset since), keeps
  /// its online pose.
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> finalPoses(const TrackerMap& map) const;

  /// The poses as published at frame time, in order.
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> onlinePoses() const;

  const std::vector<RecordedPose>& records() const { return records_; }
  void clear() { records_.clear(); }

 private:
  std::vector<RecordedPose> records_;
};

}  // namespace tracking
}  // namespace dypho
