#pragma once
/// \file global_bundle_adjuster.h
/// Global bundle adjustment (Ceres) of every keyframe and map point of the tracker's map.

#include <cstdint>
#include <set>
#include <string>

#include "dypho/tracking/local_bundle_adjuster.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// What GlobalBundleAdjuster::adjust (or RgbdOdometry's global BA) did.
struct GlobalBaResult {
  bool ran = false;              ///< an optimisation ran and its solution was applied
  int keyframes = 0;             ///< keyframes in the problem, free and fixed [count]
  int fixed_keyframes = 0;       ///< keyframes held constant (the oldest: the gauge) [count]
  int points = 0;                ///< map points optimised (seen by >= 2 keyframes) [count]
  int single_view_points = 0;    ///< points seen by one keyframe, moved with it [count]
  int observations = 0;          ///< residuals after the outlier round [count]
  int removed_observations = 0;  ///< observations dropped as chi2 outliers [count]
  double time_ms = 0.0;          ///< prepare + solve + apply, wall time [ms]
  std::string message;           ///< why it did not run; empty when it ran
};

/// Global BA calls of one RgbdOdometry (for run summaries).
struct GlobalBaStats {
  int after_loop_runs = 0;         ///< global BAs run after a loop closure [count]
  double after_loop_total_ms = 0;  ///< their summed time [ms]
  double after_loop_max_ms = 0;    ///< the longest [ms]
  GlobalBaResult last;             ///< the most recent call, after a loop or at the end
};

/// One line: "<time> ms (<keyframes> keyframes, <points> points, ...)" when it ran, else
/// "not run (<message>)".
std::string describe(const GlobalBaResult& result);
/// One line on the global BAs after loops: "<runs> runs[, <mean> ms mean, <max> ms max]".
std::string describeAfterLoop(const GlobalBaStats& stats);

/// Full BA in the style of ORB-SLAM's global BA: every keyframe of the map and every map point
/// they observe. The oldest keyframe is held fixed (the gauge; with the depth term the metric
/// scale is observable), plus any keyframe in `extra_fixed` (e.g. the first keyframe of a
/// re-initialised segment not tied to the map, whose gauge is free too). The cost is the local
/// BA's (bundle_adjustment.h: BaRgbdError, its depth row with local_ba_depth_baseline_m,
/// sigma = scale_factor^level, Huber huber_px), solved with sparse Schur in two rounds of
/// global_ba_iterations LM steps, with the chi2 outliers (chi2_threshold, chi2_threshold_depth)
/// removed from the map in between, as local BA does, each round within half of
/// global_ba_max_seconds. Writes poses and points back.
///
/// Each keyframe is held near its pose relative to the keyframe before it (by id) as the map had
/// it, by a prior of global_ba_prior_sigma_deg / _m (newBaRelativePoseError): a keyframe whose
/// multi-view points lie in a small patch of the image cannot tell a sideways shift from a turn,
/// and one such keyframe slid 12 cm without it (Bonn crowd, every 15th frame removed). A keyframe
/// without multi-view points follows its neighbours through the prior.
///
/// A point seen by a single keyframe (most of an RGB-D map: each keyframe makes points from its
/// depth) fits its one observation exactly wherever that keyframe ends up, so it adds nothing to
/// the poses: it is left out of the problem and moved rigidly with its keyframe afterwards (its
/// exact optimum; 85 % of the points on TUM fr1_rpy: 716 -> 156 ms there, back to back).
///
/// Cost grows with the observations of the multi-view points: one thread on the shared 2-core
/// VM (the range is its load), 0.1-0.4 s for 18-26 keyframes and 3-4k observations (Bonn crowd,
/// TUM fr1_rpy), 1.3-2.7 s for 81-82 keyframes and 43k observations (600-frame synthetic loop).
class GlobalBundleAdjuster {
 public:
  /// Uses global_ba_iterations, global_ba_prior_sigma_deg / _m, global_ba_max_seconds,
  /// local_ba_depth_baseline_m, huber_px, chi2_threshold(_depth), scale_factor, num_levels.
  explicit GlobalBundleAdjuster(const TrackingOptions& options);

  /// prepare + solve + apply on `map` in place; a map with fewer than two keyframes is left as it
  /// is (message set). Never throws on data.
  GlobalBaResult adjust(TrackerMap* map, const Pinhole& pinhole, const std::set<std::int64_t>& extra_fixed = {}) const;

  /// The whole map copied out (message set when there is nothing to optimise).
  LocalBaProblem prepare(const TrackerMap& map, const Pinhole& pinhole,
                         const std::set<std::int64_t>& extra_fixed = {}) const;
  /// Solves a prepared problem; reads nothing else (thread-safe on distinct problems).
  LocalBaSolution solve(const LocalBaProblem& problem) const;
  /// Writes a solution into `map` (LocalBundleAdjuster::apply's rules).
  GlobalBaResult apply(const LocalBaSolution& solution, TrackerMap* map) const;

 private:
  TrackingOptions options_;
};

}  // namespace tracking
}  // namespace dypho
