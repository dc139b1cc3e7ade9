#pragma once
/// \file loop_closer.h
/// Applies a verified loop: pose graph over all keyframes, map correction, point fusion.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/loop_detector.h"
#include "dypho/tracking/pose_graph_optimizer.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// What LoopCloser::close changed.
struct LoopCorrection {
  bool applied = false;  ///< the pose graph converged and the map was corrected
  /// Keyframes whose pose changed (> 1 mm or 0.01 deg), with the new T_world_camera.
  std::vector<std::pair<std::int64_t, Eigen::Isometry3d>> corrected_keyframes;
  /// Correction of the current keyframe, T_world_new * T_world_old^-1 (apply to poses that were
  /// estimated relative to it, e.g. the tracker's last pose).
  Eigen::Isometry3d T_correction = Eigen::Isometry3d::Identity();
  int fused_points = 0;  ///< map points merged with the old ones [count]
  std::string message;   ///< why not applied; empty otherwise
};

/// Builds the essential graph (edges between consecutive keyframes, between keyframes sharing
/// >= pose_graph_min_shared points, and the loop edge T_loop_current from the verification), all
/// relative poses taken from the current estimates except the loop edge; fixes the loop keyframe;
/// optimises (PoseGraphOptimizer); moves keyframes and their points (TrackerMap::applyKeyframePoses);
/// then fuses the matched points of the loop (current ones into the old ones).
///
/// A re-initialised segment (tracking lost for max_lost_frames, a new keyframe at a guessed pose)
/// is tied to the keyframes before it only by that guess. When the loop reaches from such a
/// segment back to a keyframe before it, the edge between the segment's first keyframe and the
/// one before it is left out: the loop places the segment, not the guess.
class LoopCloser {
 public:
  /// Uses the pose_graph_* fields.
  explicit LoopCloser(const TrackingOptions& options);

  /// `unanchored_from_keyframe_id`: the first keyframe id of the re-initialised segment not yet
  /// tied to the map (RgbdOdometry), -1 when there is none. Never throws on data.
  LoopCorrection close(TrackerMap* map, const LoopResult& loop, std::int64_t unanchored_from_keyframe_id = -1) const;

 private:
  TrackingOptions options_;
  PoseGraphOptimizer optimizer_;
};

}  // namespace tracking
}  // namespace dypho
