#pragma once
/// \file pinhole.h
/// Undistorted pinhole projection used for all tracking geometry.

#include <Eigen/Core>

#include "dypho/common/camera.h"

namespace dypho {
namespace tracking {

/// Pinhole model K without distortion. Tracking geometry works on *undistorted* pixel coordinates
/// (keypoints are undistorted once with the plumb_bob coefficients, see frame_features.h), so
/// projection is a plain K * [x/z, y/z, 1].
struct Pinhole {
  double fx = 0;  ///< focal length along u [px]
  double fy = 0;  ///< focal length along v [px]
  double cx = 0;  ///< principal point u [px]
  double cy = 0;  ///< principal point v [px]

  /// Takes fx, fy, cx, cy of `camera` (its distortion is handled by undistorting keypoints).
  static Pinhole fromIntrinsics(const CameraIntrinsics& camera) {
    return Pinhole{camera.fx, camera.fy, camera.cx, camera.cy};
  }

  /// Projects a point in the camera optical frame [m] to undistorted pixels [px]; z must be > 0.
  Eigen::Vector2d project(const Eigen::Vector3d& p_camera_m) const {
    return {fx * p_camera_m.x() / p_camera_m.z() + cx, fy * p_camera_m.y() / p_camera_m.z() + cy};
  }

  /// Back-projects undistorted pixel `uv_px` at depth `depth_m` (along the optical axis) [m].
  Eigen::Vector3d backProject(const Eigen::Vector2d& uv_px, double depth_m) const {
    return {(uv_px.x() - cx) / fx * depth_m, (uv_px.y() - cy) / fy * depth_m, depth_m};
  }
};

}  // namespace tracking
}  // namespace dypho
