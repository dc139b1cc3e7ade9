#pragma once
/// \file trajectory_io.h
/// TUM trajectory text files: one pose per line, "timestamp tx ty tz qx qy qz qw".

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/common/types.h"

namespace dypho {

/// A camera pose at a time.
struct StampedPose {
  double stamp_s = 0;  ///< time [s] (TUM files use seconds since the Unix epoch)
  /// camera optical frame in the world frame (maps camera points to world) [m]
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
};

/// Reads a TUM trajectory. Lines starting with '#' and blank lines are skipped; commas are
/// accepted as separators (as in the TUM tools). Quaternions are normalised; a zero-norm or
/// non-finite quaternion, a line with fewer than 8 numbers, or trailing junk throws
/// std::runtime_error naming "file:line". A missing file throws too.
std::vector<StampedPose> readTumTrajectory(const std::string& path);

/// Writes a TUM trajectory atomically (temporary file + rename): stamps with 6 decimals ("%.6f"),
/// translations and quaternions (qx qy qz qw, qw >= 0) with 9 significant digits. Throws
/// std::runtime_error when the file cannot be written.
void writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses);

/// (stamp [ns], T_world_camera) pairs, e.g. TrajectoryRecorder's, as StampedPose.
inline std::vector<StampedPose> toStampedPoses(const std::vector<std::pair<Timestamp, Eigen::Isometry3d>>& poses) {
  std::vector<StampedPose> out;
  out.reserve(poses.size());
  for (const auto& [stamp_ns, T_world_camera] : poses) {
    out.push_back({timestampToSeconds(stamp_ns), T_world_camera});
  }
  return out;
}

}  // namespace dypho
