#pragma once
/// \file camera_config.h
/// Camera description files (config/cameras/*.yaml) and their lookup by name or dataset folder.

#include <optional>
#include <string>
#include <vector>

#include "dypho/common/camera.h"

namespace dypho::tools {

/// A camera as described by one config/cameras/<name>.yaml file.
struct CameraConfig {
  CameraIntrinsics camera;      ///< pinhole intrinsics [px] and plumb_bob distortion of the colour image
  double depth_scale = 5000.0;  ///< raw uint16 depth value per metre: depth_m = raw / depth_scale
  /// Readout time of the colour camera's rolling shutter, top row to bottom row [ms]; optional
  /// key, 0 (the default) = global shutter. Tracking takes it when its own
  /// rolling_shutter_readout_ms is -1 (the default).
  double rolling_shutter_readout_ms = 0.0;
  std::string name;  ///< identifier, e.g. "tum_fr1"
};

/// Reads a camera YAML (keys: name, width, height, fx, fy, cx, cy, distortion[5], depth_scale;
/// optional: rolling_shutter_readout_ms). Every other key is required; unknown keys, wrong types and implausible values
/// (non-positive focal length, size or depth scale) throw std::runtime_error naming the file and the key.
CameraConfig loadCameraConfig(const std::string& yaml_path);

/// Folder holding `cameras/*.yaml`: the environment variable DYPHO_CONFIG_DIR when set, else the
/// source tree's config/ (compile definition) when it exists, else an installed
/// share/dypho_slam/config when it exists. Returns the source-tree path (even if missing) as a last
/// resort so that error messages show where files were looked for.
std::string defaultConfigDir();

/// Names of the cameras in `<config_dir>/cameras/*.yaml` (file stems), sorted.
std::vector<std::string> listCameraNames(const std::string& config_dir);

/// "tum_fr1" -> "<config_dir>/cameras/tum_fr1.yaml". An existing file path is returned as is.
/// Throws std::runtime_error listing the known names when neither exists.
std::string resolveCameraConfig(const std::string& name_or_path, const std::string& config_dir);

/// Guesses the camera of a TUM-layout dataset folder, in this order:
///  1. a `camera.yaml` inside the folder -> its path;
///  2. a TUM header line "# file: 'rgbd_dataset_freiburg1_....bag'" in rgb.txt -> "tum_fr1"
///     (freiburg2 -> "tum_fr2", freiburg3 -> "tum_fr3");
///  3. the folder name containing "freiburg1"/"fr1" (2, 3 likewise) -> "tum_frN";
///  4. the folder name containing "bonn" -> "bonn".
/// Returns std::nullopt when none applies.
std::optional<std::string> detectCameraName(const std::string& dataset_dir);

}  // namespace dypho::tools
