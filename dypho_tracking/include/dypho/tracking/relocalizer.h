#pragma once
/// \file relocalizer.h
/// Finds the pose of a frame against the keyframes of the map after tracking was lost.

#include <cstdint>
#include <string>

#include <Eigen/Geometry>

#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/keyframe_aligner.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {

/// Result of Relocalizer::relocalize.
struct RelocalizationResult {
  bool success = false;           ///< pose found with >= relocalization_min_inliers inliers
  std::int64_t keyframe_id = -1;  ///< keyframe it was found against
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();  ///< the pose found
  int num_inliers = 0;  ///< pose inliers against that keyframe's local map [count]
  int tried = 0;        ///< keyframes tried [count]
  std::string message;  ///< why it failed; empty on success
};

/// Relocalisation: candidates are the keyframes of the map, newest first (at most
/// relocalization_max_keyframes, spread evenly over the map when it has more). Against each
/// candidate's own map points: KeyframeAligner (projection from the keyframe's pose, otherwise
/// brute-force descriptor matching + EPnP RANSAC, Ceres refinement); on success the pose is
/// refined once more against the candidate's local map (covisible keyframes). The first candidate
/// reaching relocalization_min_inliers wins, or with `most_inliers` the candidate with most inliers
/// (a search with no pose to go by, where the first one good enough may be a wrong place).
class Relocalizer {
 public:
  /// Throws std::invalid_argument when options.validate() does.
  explicit Relocalizer(const TrackingOptions& options);

  /// Never throws on data. `times` (may be null) accumulates matching/pnp/refine.
  RelocalizationResult relocalize(const TrackerMap& map, const FrameFeatures& frame, const Pinhole& pinhole,
                                  TrackingTimesMs* times, bool most_inliers = false) const;

 private:
  TrackingOptions options_;
  KeyframeAligner aligner_;
};

}  // namespace tracking
}  // namespace dypho
