#pragma once
/// \file loop_detector.h
/// Loop-closure candidates and their geometric verification, without a vocabulary file.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/tracking/keyframe_aligner.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// A verified loop between the newest keyframe and an old one.
struct LoopResult {
  bool found = false;                     ///< a candidate passed the geometric verification
  std::int64_t current_keyframe_id = -1;  ///< the newest keyframe
  std::int64_t loop_keyframe_id = -1;     ///< the old keyframe it closes onto
  /// Pose of the current keyframe measured against the old keyframe's local map (i.e. in the
  /// old, less drifted part of the world).
  Eigen::Isometry3d T_world_current = Eigen::Isometry3d::Identity();
  int num_inliers = 0;  ///< pose inliers of the verification [count]
  /// (old map-point id, current keyframe's map-point id) of the inlier matches, for fusion.
  std::vector<std::pair<std::int64_t, std::int64_t>> point_matches;
  int candidates = 0;   ///< candidates verified [count]
  std::string message;  ///< why no loop was accepted (empty when found)
};

/// Loop detection by place proximity and descriptor matching (no bag-of-words vocabulary to
/// ship). Candidates for the current keyframe K: keyframes at least loop_min_keyframe_gap ids
/// older, sharing fewer than covisibility_min_shared points with K (not already connected),
/// whose estimated camera centre lies within loop_search_radius_m of K's and whose optical axis
/// is within loop_max_angle_deg of K's; the loop_max_candidates nearest are verified.
/// Verification: K's features against the candidate's local map (KeyframeAligner: projection from
/// K's drifted pose, otherwise brute-force descriptor matching + EPnP RANSAC; Ceres refinement);
/// accepted with >= loop_min_inliers inliers. With drift larger than loop_search_radius_m the loop
/// is missed (documented limit; a vocabulary-based place recogniser would remove it).
class LoopDetector {
 public:
  /// Throws std::invalid_argument when options.validate() does.
  explicit LoopDetector(const TrackingOptions& options);

  /// Never throws on data.
  LoopResult detect(const TrackerMap& map, std::int64_t current_keyframe_id, const Pinhole& pinhole) const;

 private:
  TrackingOptions options_;
  KeyframeAligner aligner_;
};

}  // namespace tracking
}  // namespace dypho
