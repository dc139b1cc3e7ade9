#pragma once
/// \file bundle_adjustment.h
/// The bundle-adjustment machinery shared by LocalBundleAdjuster and GlobalBundleAdjuster
/// (private to dypho_tracking_core): one copy of the problem set-up, the solve with its chi2
/// outlier round, and the write-back into the map. The two adjusters differ only in which
/// keyframes they put into the problem, which they hold fixed, and the solver settings.

#include <cstdint>
#include <set>

#include "dypho/tracking/local_bundle_adjuster.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// How solveBundleAdjustment runs Ceres.
struct BaSolverSettings {
  int iterations = 5;   ///< Levenberg-Marquardt steps per round (two rounds) [count]
  bool sparse = false;  ///< sparse Schur (many keyframes) instead of dense Schur (a small window)
  /// Wall-time limit of each of the two rounds (Ceres's max_solver_time_in_seconds: it stops
  /// with the best solution so far) [s]; 0: none.
  double max_seconds_per_round = 0.0;
};

/// Puts the points `point_ids` (existing map points) into `problem`, whose keyframes
/// (T_world_keyframe, fixed) are set: a point two or more of those keyframes see into p_world_m,
/// a point one of them sees into single_view_points (solveBundleAdjustment moves it with that
/// keyframe; it adds nothing to the poses).
void addBaPoints(const TrackerMap& map, const std::set<std::int64_t>& point_ids, LocalBaProblem* problem);

/// Copies into `problem` one observation per (keyframe, point) pair of the problem's keyframes
/// (T_world_keyframe) and points (p_world_m): undistorted keypoint, level (clamped to
/// num_levels - 1) and measured depth.
void addBaObservations(const TrackerMap& map, const TrackingOptions& options, LocalBaProblem* problem);

/// Solves `problem`: a BaRgbdError per observation, with its depth row where a depth was measured
/// (when local_ba_depth_baseline_m > 0), whitened by scale_factor^level, Huber (huber_px); a round of
/// `settings.iterations` LM steps, removal of the chi2 outliers (chi2_threshold, or
/// chi2_threshold_depth with the depth term), a second round; then each single-view point of a
/// free keyframe moves with it (T_world_new T_world_old^-1; a fixed keyframe's stay). Reads
/// nothing else (thread-safe on distinct problems).
LocalBaSolution solveBundleAdjustment(const LocalBaProblem& problem, const TrackingOptions& options,
                                      const BaSolverSettings& settings);

/// Writes `solution` into `map`: free keyframes' poses, points (single-view ones too), and the
/// outlier observations removed (a point's last observation is kept); skips keyframes, points and
/// observations removed or re-assigned since the problem was prepared.
LocalBaResult applyBundleAdjustment(const LocalBaSolution& solution, TrackerMap* map);

}  // namespace tracking
}  // namespace dypho
