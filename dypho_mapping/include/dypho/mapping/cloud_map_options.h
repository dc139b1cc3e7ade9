#pragma once
/// \file cloud_map_options.h
/// Settings of the keyframe point-cloud map (`KeyframeCloudMap`).

#include <cstddef>
#include <string>

namespace dypho {
namespace mapping {

/// Settings of `KeyframeCloudMap`.
struct CloudMapOptions {
  /// Every pixel_stride-th pixel along rows and columns is unprojected [px], >= 1. Default 4.
  int pixel_stride = 4;
  /// Depths below this are ignored [m], >= 0. Default 0.1.
  double min_depth_m = 0.1;
  /// Depths above this are ignored [m], > min_depth_m. Default 4.0.
  double max_depth_m = 4.0;
  /// Leaf size of the voxel-grid filter applied by `buildCloud()` [m], >= 0 (0 = no filter).
  /// Default 0.02.
  double voxel_size_m = 0.02;
  /// Hard cap on the points stored over all keyframes (before voxel filtering), >= 1. When a new
  /// keyframe would exceed it, that keyframe is skipped (oldest data kept). Default 2 000 000.
  std::size_t max_points = 2000000;

  /// Throws std::invalid_argument naming the first field that is out of range and its range.
  void validate() const;
  /// One line "key=value ..." with every field, for start-up logs.
  std::string toString() const;
};

}  // namespace mapping
}  // namespace dypho
