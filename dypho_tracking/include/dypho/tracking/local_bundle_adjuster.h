#pragma once
/// \file local_bundle_adjuster.h
/// Local bundle adjustment (Ceres) of the newest keyframes and the points they see.

#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// What LocalBundleAdjuster::adjust did.
struct LocalBaResult {
  bool ran = false;              ///< an optimisation ran and its solution was applied
  int optimized_keyframes = 0;   ///< keyframes whose pose was free [count]
  int fixed_keyframes = 0;       ///< keyframes held constant (they see the points) [count]
  int points = 0;                ///< map points optimised [count]
  int single_view_points = 0;    ///< points seen by one free keyframe, moved with it [count]
  int observations = 0;          ///< residuals [count]
  int removed_observations = 0;  ///< observations dropped as chi2 outliers [count]
  std::string message;           ///< why it did not run; empty when it ran
};

/// One observation of a LocalBaProblem, copied out of the map.
struct LocalBaObservation {
  std::int64_t keyframe_id = -1;
  std::int64_t point_id = -1;
  int feature_index = -1;                           ///< keypoint index in the keyframe
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  ///< undistorted keypoint [px]
  int level = 0;                                    ///< pyramid level
  double depth_m = 0.0;                             ///< measured depth, 0 = none
  /// The point's image motion over its keyframe's exposure at the start [px] (motion_blur.h);
  /// zero = sharp.
  Eigen::Vector2d blur_streak_px = Eigen::Vector2d::Zero();
};

/// A local BA window copied out of the map (LocalBundleAdjuster::prepare): solving it touches
/// nothing shared, so it may run on another thread while tracking goes on.
/// A prior on the relative pose of two keyframes of a BA problem (newBaRelativePoseError).
struct KeyframePairPrior {
  std::int64_t from = -1;                                       ///< keyframe a
  std::int64_t to = -1;                                         ///< keyframe b
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();  ///< T_world_a^-1 T_world_b
  double sigma_rot_rad = 0.0;                                   ///< > 0 [rad]
  double sigma_trans_m = 0.0;                                   ///< > 0 [m]
};

/// A point that one keyframe of a BA problem sees and no other: it fits that observation
/// wherever the keyframe ends up, so it is left out of the problem and moves rigidly with its
/// keyframe (most of an RGB-D map: each keyframe makes points from its depth).
struct SingleViewPoint {
  std::int64_t point_id = -1;
  std::int64_t keyframe_id = -1;                        ///< the keyframe that sees it
  Eigen::Vector3d p_world_m = Eigen::Vector3d::Zero();  ///< its position when prepared
};

struct LocalBaProblem {
  std::int64_t newest_keyframe_id = -1;
  std::map<std::int64_t, Eigen::Isometry3d> T_world_keyframe;   ///< free and fixed keyframes
  std::map<std::int64_t, bool> fixed;                           ///< keyframe id -> held constant
  std::unordered_map<std::int64_t, Eigen::Vector3d> p_world_m;  ///< map points in the problem
  std::vector<SingleViewPoint> single_view_points;              ///< left out, moved with their keyframe
  std::vector<LocalBaObservation> observations;
  std::vector<KeyframePairPrior> pose_priors;  ///< global BA's; none in local BA
  Pinhole pinhole;
  std::string message;  ///< why there is nothing to solve; empty when there is
};

/// What LocalBundleAdjuster::solve found, to be written back by apply().
struct LocalBaSolution {
  bool usable = false;
  std::int64_t newest_keyframe_id = -1;
  std::map<std::int64_t, Eigen::Isometry3d> T_world_keyframe;   ///< the free keyframes' poses
  std::unordered_map<std::int64_t, Eigen::Vector3d> p_world_m;  ///< the points' positions
  /// The single-view points of free keyframes, moved with them (written back with p_world_m).
  std::unordered_map<std::int64_t, Eigen::Vector3d> p_world_single_view_m;
  std::vector<LocalBaObservation> outliers;  ///< observations to remove
  int fixed_keyframes = 0;
  int observations = 0;
  std::string message;  ///< why it is not usable
};

/// Local BA in the style of ORB-SLAM: free = the newest keyframe and its local_ba_keyframes - 1
/// most covisible keyframes; points = every map point they observe; fixed = up to
/// local_ba_max_fixed_keyframes other keyframes observing those points (at least one keyframe is
/// always fixed: when none is, the oldest of the window is fixed, which fixes the gauge).
/// Cost: a BaRgbdError per observation, with its depth row where the keyframe measured a depth
/// (when local_ba_depth_baseline_m > 0; fixes the metric scale), whitened by sigma = scale_factor^level,
/// Huber (huber_px); two rounds of local_ba_iterations LM steps (dense Schur); after the first,
/// observations with chi2 > chi2_threshold (chi2_threshold_depth with the depth term) are
/// removed from the map (a point's last observation is kept). A point that only one keyframe of
/// the window sees (most of an RGB-D window: each keyframe makes points from its depth) adds
/// nothing to the poses: it is left out and moved rigidly with that keyframe, as the global BA
/// does (the window's points on TUM fr1/rpy: about 800 of 3000). Writes poses and points back
/// into the map. adjust() does it at once (a keyframe's tracking about 60-85 ms on one core of the
/// 2-core VM, 115-170 ms with every point in the problem); prepare(), solve()
/// and apply() split it so that solve() can run beside tracking (RgbdOdometry,
/// TrackingOptions::local_ba_async_frames).
class LocalBundleAdjuster {
 public:
  /// Uses the local_ba_* fields, huber_px, chi2_threshold, scale_factor.
  explicit LocalBundleAdjuster(const TrackingOptions& options);

  /// `map`: the map to adjust in place; `newest_keyframe_id`: the window's anchor. `pinhole` is
  /// the camera (all keyframes share it). Never throws on data.
  LocalBaResult adjust(TrackerMap* map, std::int64_t newest_keyframe_id, const Pinhole& pinhole) const;

  /// The window of `newest_keyframe_id`, copied out of `map` (message set when there is none).
  LocalBaProblem prepare(const TrackerMap& map, std::int64_t newest_keyframe_id, const Pinhole& pinhole) const;
  /// Solves a prepared window; reads nothing else (thread-safe on distinct problems).
  LocalBaSolution solve(const LocalBaProblem& problem) const;
  /// Writes a solution into `map`, skipping keyframes, points and observations that were removed
  /// or re-assigned since the window was prepared.
  LocalBaResult apply(const LocalBaSolution& solution, TrackerMap* map) const;

 private:
  TrackingOptions options_;
};

}  // namespace tracking
}  // namespace dypho
