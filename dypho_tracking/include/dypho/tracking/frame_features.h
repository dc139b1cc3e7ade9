#pragma once
/// \file frame_features.h
/// Keypoints of one frame with their undistorted coordinates, depth and 3D point.

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "dypho/common/camera.h"
#include "dypho/tracking/orb_extractor.h"

namespace dypho {
namespace tracking {

/// Features of one frame ready for geometry. All vectors have the same length; index i is one
/// keypoint. Only keypoints with a valid depth are kept (see makeFrameFeatures).
struct FrameFeatures {
  /// Keypoints in the input (distorted) image, level-0 [px]; octave = pyramid level.
  std::vector<cv::KeyPoint> keypoints;
  /// Undistorted pixel coordinates (pinhole K of the camera) [px].
  std::vector<Eigen::Vector2d> uv_undistorted_px;
  /// Depth measured at the (distorted) keypoint pixel [m].
  std::vector<float> depth_m;
  /// Back-projected point in the camera optical frame [m].
  std::vector<Eigen::Vector3d> p_camera_m;
  /// Row i = 32-byte ORB descriptor of keypoint i (CV_8UC1).
  cv::Mat descriptors;
  /// Rows of the input image [px]; the rolling shutter's row times are relative to it. 0 = unknown
  /// (every keypoint then counts as seen at the stamp).
  int image_rows = 0;

  /// Number of keypoints.
  std::size_t size() const { return keypoints.size(); }
};

/// Undistorts pixel coordinates of the input image with the plumb_bob model of `camera` and
/// returns undistorted pixel coordinates for the same K (iterative, 20 iterations, converged to
/// well below 0.01 px for TUM fr1). Identity when the camera has no distortion.
std::vector<Eigen::Vector2d> undistortPixels(const std::vector<cv::Point2f>& distorted_px,
                                             const CameraIntrinsics& camera);

/// Builds FrameFeatures from extracted ORB features. The depth of a keypoint is read at its
/// rounded pixel in the *original* (distorted) image, because the depth image is registered to that
/// image. Keypoints whose depth is 0, NaN or outside [min_depth_m, max_depth_m] are DROPPED: this
/// milestone uses only points with a metric 3D position (a later milestone may keep them as
/// 2D-only observations). `depth_m` must be CV_32FC1 with the image size (not checked here).
FrameFeatures makeFrameFeatures(const OrbFeatures& orb, const cv::Mat& depth_m, const CameraIntrinsics& camera,
                                double min_depth_m, double max_depth_m);

}  // namespace tracking
}  // namespace dypho
