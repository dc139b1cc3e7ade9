#pragma once
/// \file mapping_options_fields.h
/// The list of CloudMapOptions keys, written once: parameter readers (ROS private params, YAML
/// files) and printers visit the fields through `visitOptions`. Keep it in the order of the struct.

#include "dypho/mapping/cloud_map_options.h"

namespace dypho::mapping {

/// Calls `visitor(key, field, doc)` for every field of `options`.
template <typename Visitor>
void visitOptions(CloudMapOptions& options, Visitor&& visitor) {
  visitor("pixel_stride", options.pixel_stride, "Every pixel_stride-th pixel along rows and columns is unprojected [px], >= 1. Default 4.");
  visitor("min_depth_m", options.min_depth_m, "Depths below this are ignored [m], >= 0. Default 0.1.");
  visitor("max_depth_m", options.max_depth_m, "Depths above this are ignored [m], > min_depth_m. Default 4.0.");
  visitor("voxel_size_m", options.voxel_size_m, "Leaf size of the voxel-grid filter applied by `buildCloud()` [m], >= 0 (0 = no filter). Default 0.02.");
  visitor("max_points", options.max_points, "Hard cap on the points stored over all keyframes (before voxel filtering), >= 1. When a new keyframe would exceed it, that keyframe is skipped (oldest data kept). Default 2 000 000.");
}

}  // namespace dypho::mapping
