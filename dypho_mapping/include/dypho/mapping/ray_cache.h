#pragma once
/// \file ray_cache.h
/// Per-camera table of undistorted viewing rays, one per pixel.

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/camera.h"

namespace dypho {
namespace mapping {

/// For each pixel (u, v) of a camera, the normalised undistorted image coordinates (x, y) such that
/// the ray through the pixel is (x, y, 1) in the camera optical frame, i.e. a point at z-depth d is
/// d * (x, y, 1). Tables are computed once per distinct `CameraIntrinsics` (all fields compared) and
/// kept; the least recently used one is dropped beyond `max_cameras`.
class UndistortedRayCache {
 public:
  /// `max_cameras` >= 1 tables are kept (one 640x480 table is 2.4 MB).
  explicit UndistortedRayCache(std::size_t max_cameras = 4);

  /// CV_32FC2 table of size camera.height x camera.width. Throws std::invalid_argument when
  /// `camera.valid()` is false.
  std::shared_ptr<const cv::Mat> rays(const CameraIntrinsics& camera);

  /// Number of tables held.
  std::size_t size() const { return entries_.size(); }

  /// Computes a table without caching (pinhole in closed form; distorted cameras through
  /// cv::undistortPoints, iterated to 1e-6 px).
  static cv::Mat computeRays(const CameraIntrinsics& camera);

 private:
  std::size_t max_cameras_;
  /// Most recently used last.
  std::vector<std::pair<CameraIntrinsics, std::shared_ptr<const cv::Mat>>> entries_;
};

}  // namespace mapping
}  // namespace dypho
