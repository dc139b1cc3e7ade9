#pragma once
/// \file keyframe_cloud_map.h
/// Coloured point-cloud map made of the static pixels of keyframes. Each keyframe's points are kept
/// in its own camera frame, so a pose correction (loop closure, bundle adjustment) re-anchors them
/// without recomputation. This is the milestone's map; the 3D Gaussian map of the paper builds on
/// the same keyframe input later.

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "dypho/common/types.h"
#include "dypho/mapping/cloud_map_options.h"
#include "dypho/mapping/ray_cache.h"

namespace dypho {
namespace mapping {

/// What `KeyframeCloudMap::buildCloud` did.
struct CloudBuildReport {
  std::size_t input_points = 0;   ///< points before the voxel filter (all keyframes, world frame)
  std::size_t output_points = 0;  ///< points returned
  double leaf_size_m = 0.0;       ///< voxel leaf actually used [m] (0 = no filter)
  bool coarser_leaf = false;      ///< true when the configured leaf would overflow PCL's indices
  std::string message;            ///< explanation when `coarser_leaf` is true
};

/// The keyframes of a KeyframeCloudMap at one moment: their poses and their (immutable, shared)
/// points. Cheap to take (no point is copied); building the cloud from it needs no lock on the map.
struct KeyframeCloudSnapshot {
  using Cloud = pcl::PointCloud<pcl::PointXYZRGB>;
  struct Entry {
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
    std::shared_ptr<const Cloud> points_camera;  ///< in the keyframe's camera optical frame [m]
  };
  std::vector<Entry> keyframes;
  std::size_t num_points = 0;  ///< sum of the entries' points
  double voxel_size_m = 0.0;   ///< leaf of the voxel filter (CloudMapOptions::voxel_size_m)
};

/// World-frame coloured cloud of `snapshot`, voxel-grid filtered with its `voxel_size_m`
/// (pcl::VoxelGrid averages position and colour per voxel). When the extent of the map with that
/// leaf would overflow PCL's 32-bit voxel indices, a coarser leaf is used and `report` says so.
/// Thread-safe: reads only the snapshot.
KeyframeCloudSnapshot::Cloud::Ptr buildCloud(const KeyframeCloudSnapshot& snapshot, CloudBuildReport* report = nullptr);

/// Keyframe point-cloud map. Not thread-safe (the mapping worker owns it).
///
/// Capacity: at most `CloudMapOptions::max_points` points are stored. A keyframe that would exceed
/// the cap is skipped as a whole (`addKeyframe` returns 0 and `capacityReached()` becomes true);
/// the points already stored (the oldest) are kept. Memory therefore never grows without bound.
class KeyframeCloudMap {
 public:
  using Cloud = pcl::PointCloud<pcl::PointXYZRGB>;

  /// Validates `options` (std::invalid_argument on a bad value).
  explicit KeyframeCloudMap(const CloudMapOptions& options);

  /// Adds the static (mask == 0, or no mask), valid-depth pixels of `keyframe`, sampled every
  /// `pixel_stride` pixels from (0, 0), with depth in [min_depth_m, max_depth_m]. Pixels are
  /// unprojected with the keyframe's intrinsics including distortion (rays cached per camera) and
  /// stored in the keyframe's camera frame. A keyframe with an id already in the map replaces it.
  /// Returns the number of points added (0 when skipped for capacity).
  /// Throws std::invalid_argument for a negative id, a non-finite or non-rigid pose, empty images,
  /// wrong image types, mismatched sizes or invalid intrinsics (callers log and skip).
  std::size_t addKeyframe(const Keyframe& keyframe);

  /// Re-anchors keyframe `id` after a pose correction. Returns false when the id is unknown.
  /// Throws std::invalid_argument for a non-finite or non-rigid pose.
  bool updateKeyframePose(std::int64_t id, const Eigen::Isometry3d& T_world_camera);

  /// The keyframes as they are now (poses and shared points); see `buildCloud(snapshot)`.
  KeyframeCloudSnapshot snapshot() const;
  /// `dypho::mapping::buildCloud(snapshot())`: all keyframes, world frame, voxel filtered.
  Cloud::Ptr buildCloud(CloudBuildReport* report = nullptr) const;

  /// Writes `buildCloud()` as a binary PCD, atomically: a temporary file in the same folder is
  /// written and then renamed over `path`. Throws std::runtime_error naming the path on failure
  /// (missing folder, not writable, disk full); no temporary file is left behind.
  void savePcd(const std::string& path) const;

  std::size_t numKeyframes() const { return keyframes_.size(); }  ///< keyframes stored
  std::size_t numPoints() const { return num_points_; }           ///< points stored (before voxel filter)
  /// True once a keyframe has been skipped because of `max_points` (cleared by `reset()`).
  bool capacityReached() const { return capacity_reached_; }
  /// Removes every keyframe (the ray tables are kept).
  void reset();

  const CloudMapOptions& options() const { return options_; }  ///< the options in use

 private:
  struct StoredKeyframe {
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
    /// points in the keyframe's camera optical frame [m]; never changed once stored (snapshots share it)
    std::shared_ptr<const Cloud> points_camera;
  };

  CloudMapOptions options_;
  UndistortedRayCache rays_;
  std::map<std::int64_t, StoredKeyframe> keyframes_;
  std::size_t num_points_ = 0;
  bool capacity_reached_ = false;
};

}  // namespace mapping
}  // namespace dypho
