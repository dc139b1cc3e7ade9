#pragma once
/// \file odom_frame.h
/// REP-105's `map` -> `odom` for the published poses: `odom` -> camera stays smooth, `map` ->
/// `odom` takes the jumps. The tracker's own odometry frame (TrackingResult::T_world_odom)
/// already takes its loop corrections; this adds the jumps it does not: a relocalisation after
/// being lost and the camera found in a restored session's map. At such a jump `odom` -> camera
/// keeps the last published value (the odometry knows no motion across the gap) and `map` ->
/// `odom` moves by the whole jump.

#include <optional>

#include <Eigen/Geometry>

namespace dypho::tracking {

class OdomFrame {
 public:
  /// T_map_odom for the published pose `T_map_camera`, given the tracker's loop-correction frame
  /// `T_map_odom_tracker`; `jumped`: the pose jumped (relocalised, found in a restored map).
  Eigen::Isometry3d update(const Eigen::Isometry3d& T_map_camera, const Eigen::Isometry3d& T_map_odom_tracker,
                           bool jumped);
  /// A new world (the tracker was reset): odom starts again at the tracker's odometry frame.
  void reset();

 private:
  /// The tracker's odometry frame to the published one (the jumps so far).
  Eigen::Isometry3d T_trackerodom_odom_ = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> T_odom_camera_last_;  ///< the last published odom -> camera
};

}  // namespace dypho::tracking
