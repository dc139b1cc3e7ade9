#pragma once
/// \file trajectory_recorder.h
/// Per-frame poses kept relative to their reference keyframe, so that the saved trajectory
/// follows the keyframe corrections of local BA and loop closure made after the frame was tracked
/// (the trajectory ORB-SLAM saves), its positions fitted locally in time (smoothPositions). The
/// poses published at frame time are kept as well.

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/common/types.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {

/// One recorded frame.
struct RecordedPose {
  Timestamp stamp_ns = 0;
  std::int64_t reference_keyframe_id = -1;  ///< -1: not tracked (no pose to refine)
  Eigen::Isometry3d T_reference_camera = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_camera_online = Eigen::Isometry3d::Identity();  ///< as published
  bool discontinuous = false;  ///< a new segment starts here (TrackingResult::discontinuous)
};

/// How smoothPositions fits a trajectory's positions in time.
struct PositionSmoothing {
  /// Half width of the window [s]; <= 0: no smoothing (TrackingOptions::trajectory_smoothing_s).
  double half_window_s = 0.0;
  /// A position farther from its fit than this many sigma weighs less (Huber: weight limit /
  /// distance), sigma estimated from the median distance; 0 = plain least squares
  /// (TrackingOptions::trajectory_smoothing_outlier_sigmas).
  double outlier_sigmas = 0.0;
};

/// The smoothing TrackingOptions ask for.
PositionSmoothing positionSmoothing(const TrackingOptions& options);

/// Fits each position of a trajectory locally in time: the straight line through the positions
/// of its segment within +-half_window_s of it (least squares), evaluated at its stamp.
/// `segment_ids` (one per pose): poses with the same id form one continuous motion; -1 = a pose
/// that is neither changed nor used (a lost frame holding an old pose). Poses in time order;
/// rotations are kept; a pose with fewer than three in its window keeps its position.
/// Per-frame translation noise is independent from frame to frame, a camera's motion is smooth:
/// at 30 Hz and +-75 ms the noise falls by about sqrt(5), and a 1 m/s^2 acceleration is off by
/// about 1 mm. A line through the window follows a constant velocity exactly, so one-sided windows
/// (segment ends) are not dragged back. With outlier_sigmas > 0 the fit is then repeated three
/// times with Huber weights from each position's distance to its previous fit: a frame whose pose
/// is centimetres off (a blurred frame in a fast turn) neither pulls its neighbours' fits nor
/// keeps its own error, while Gaussian noise is fitted as before. half_window_s <= 0: unchanged.
void smoothPositions(const PositionSmoothing& smoothing, const std::vector<int>& segment_ids,
                     std::vector<std::pair<Timestamp, Eigen::Isometry3d>>* poses);

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
  /// its online pose. With smoothing.half_window_s > 0 (positionSmoothing(TrackingOptions)) the
  /// tracked frames' positions are then fitted in time (smoothPositions), segments split where a
  /// frame was discontinuous or lost.
  /// With first_record > 0 only the records from that index on are re-expressed and fitted (the
  /// fit's windows end there): the cost of a caller that shows the newest poses stays bounded.
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> finalPoses(const TrackerMap& map,
                                                                  const PositionSmoothing& smoothing = {},
                                                                  std::size_t first_record = 0) const;

  /// The poses as published at frame time, in order.
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> onlinePoses() const;

  const std::vector<RecordedPose>& records() const { return records_; }
  /// For a refinement of the relative poses (FinalFrameRefiner).
  std::vector<RecordedPose>* mutableRecords() { return &records_; }
  void clear() { records_.clear(); }

 private:
  std::vector<RecordedPose> records_;
};

}  // namespace tracking
}  // namespace dypho
