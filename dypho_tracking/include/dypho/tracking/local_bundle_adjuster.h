#pragma once
/// \file local_bundle_adjuster.h
/// Local bundle adjustment (Ceres) of the newest keyframes and the points they see.

#include <cstdint>
#include <string>

#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// What LocalBundleAdjuster::adjust did.
struct LocalBaResult {
  bool ran = false;            ///< an optimisation ran and its solution was applied
  int optimized_keyframes = 0;  ///< keyframes whose pose was free [count]
  int fixed_keyframes = 0;      ///< keyframes held constant (they see the points) [count]
  int points = 0;               ///< map points optimised [count]
  int observations = 0;         ///< residuals [count]
  int removed_observations = 0;  ///< observations dropped as chi2 outliers [count]
  std::string message;          ///< why it did not run; empty when it ran
};

/// Local BA in the style of ORB-SLAM: free = the newest keyframe and its local_ba_keyframes - 1
/// most covisible keyframes; points = every map point they observe; fixed = up to
/// local_ba_max_fixed_keyframes other keyframes observing those points (at least one keyframe is
/// always fixed: when none is, the oldest of the window is fixed, which fixes the gauge).
/// Cost: BaReprojectionError plus BaDepthError where the keyframe measured a depth (when
/// local_ba_depth_baseline_m > 0; fixes the metric scale), whitened by sigma = scale_factor^level,
/// Huber (huber_px); two rounds of local_ba_iterations LM steps (sparse Schur); after the first,
/// observations with chi2 > chi2_threshold (chi2_threshold_depth with the depth term) are
/// removed from the map (a point's last observation is kept). Writes poses and points back into the map. Synchronous (~10-40 ms per keyframe
/// at 1000 features on one core).
class LocalBundleAdjuster {
 public:
  /// Uses the local_ba_* fields, huber_px, chi2_threshold, scale_factor.
  explicit LocalBundleAdjuster(const TrackingOptions& options);

  /// `map`: the map to adjust in place; `newest_keyframe_id`: the window's anchor. `pinhole` is
  /// the camera (all keyframes share it). Never throws on data.
  LocalBaResult adjust(TrackerMap* map, std::int64_t newest_keyframe_id,
                       const Pinhole& pinhole) const;

 private:
  TrackingOptions options_;
};

}  // namespace tracking
}  // namespace dypho
