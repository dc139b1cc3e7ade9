#pragma once
/// \file camera.h
/// Pinhole camera with optional radial-tangential distortion, shared by all modules.

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <opencv2/core/types.hpp>

namespace dypho {

/// Intrinsics of the colour camera that the depth image is registered to.
///
/// Pixel convention: (u, v) with u to the right and v down, origin at the centre of the top-left
/// pixel (OpenCV convention). Distortion follows OpenCV's plumb_bob model (k1 k2 p1 p2 k3), the
/// same as `sensor_msgs/CameraInfo` with `distortion_model: plumb_bob`.
struct CameraIntrinsics {
  double fx = 0.0;  ///< focal length along u [px]
  double fy = 0.0;  ///< focal length along v [px]
  double cx = 0.0;  ///< principal point u [px]
  double cy = 0.0;  ///< principal point v [px]
  int width = 0;    ///< image width [px]
  int height = 0;   ///< image height [px]
  /// plumb_bob distortion k1 k2 p1 p2 k3 (all zero = already rectified).
  std::array<double, 5> distortion{{0.0, 0.0, 0.0, 0.0, 0.0}};

  /// True when the numbers describe a usable camera (positive focal lengths and size).
  bool valid() const { return fx > 0.0 && fy > 0.0 && width > 0 && height > 0; }

  /// True when any distortion coefficient is non-zero.
  bool distorted() const {
    for (double d : distortion) {
      if (d != 0.0) return true;
    }
    return false;
  }
};

/// True when every number of `a` equals that of `b` (intrinsics, size and distortion): caches
/// keyed by a camera are valid for the other.
inline bool sameCamera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.width == b.width && a.height == b.height &&
         a.distortion == b.distortion;
}

/// Size of an image of `width` x `height` resized by `scale` (rounded, at least 1 x 1).
inline cv::Size scaledImageSize(int width, int height, double scale) {
  return cv::Size(std::max(1, static_cast<int>(std::lround(width * scale))),
                  std::max(1, static_cast<int>(std::lround(height * scale))));
}

/// Intrinsics of an image resized by `scale` to `width` x `height` (cv::resize pixel-centre
/// convention); the distortion coefficients act on normalised coordinates and are kept.
inline CameraIntrinsics resizedIntrinsics(const CameraIntrinsics& c, const cv::Size& size, double scale) {
  CameraIntrinsics s = c;
  s.fx *= scale;
  s.fy *= scale;
  s.cx = (c.cx + 0.5) * scale - 0.5;
  s.cy = (c.cy + 0.5) * scale - 0.5;
  s.width = size.width;
  s.height = size.height;
  return s;
}

/// `c` resized by `scale` (scaledImageSize, resizedIntrinsics).
inline CameraIntrinsics scaledCamera(const CameraIntrinsics& c, double scale) {
  return resizedIntrinsics(c, scaledImageSize(c.width, c.height, scale), scale);
}

}  // namespace dypho
