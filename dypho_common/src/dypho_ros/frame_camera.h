#pragma once
/// \file frame_camera.h
/// Where the mask and tracking nodelets take the colour camera's intrinsics from: each frame's
/// CameraInfo, or a camera file (config/cameras/*.yaml) that replaces it. The file is for bags
/// and drivers that publish nominal values instead of a calibration: TUM's published RGB-D bags
/// carry the OpenNI driver's 525 px / image-centre / no-distortion CameraInfo, while their images
/// were taken through the calibrated lenses of config/cameras/tum_fr{1,2,3}.yaml.

#include <atomic>
#include <optional>
#include <string>

#include <sensor_msgs/CameraInfo.h>

#include "dypho/common/camera.h"

namespace dypho::ros_conversions {

/// True when `info` holds a driver's nominal values rather than a calibration: no distortion,
/// fx == fy, and the principal point exactly at the image centre ((width-1)/2, (height-1)/2).
/// This is what openni_camera publishes for an uncalibrated Kinect (and what TUM's bags carry).
bool looksLikeNominalCalibration(const sensor_msgs::CameraInfo& info);

/// The intrinsics of each frame (one per nodelet; thread-safe).
class FrameCamera {
 public:
  /// camera_file: empty = every frame's CameraInfo as it comes; else the intrinsics of this
  /// camera file (config/cameras/*.yaml format) replace them. Throws std::runtime_error naming the
  /// file and the key when it cannot be read.
  explicit FrameCamera(const std::string& camera_file);

  /// The intrinsics of a frame whose CameraInfo is `info`. With a camera file: the file's, after
  /// checking that its size is the CameraInfo's (ConversionError naming both otherwise). Without:
  /// toCameraIntrinsics(info). `warning_once`, when given, receives a warning the first time a
  /// CameraInfo with nominal values (looksLikeNominalCalibration) is taken as it comes.
  CameraIntrinsics intrinsics(const sensor_msgs::CameraInfo& info, std::string* warning_once = nullptr) const;

  /// One line for the start-up log: where the intrinsics come from.
  std::string describe() const;

  /// The camera file's rolling-shutter readout [ms] (0 = a global shutter); nullopt without a file.
  std::optional<double> rollingShutterReadoutMs() const { return file_readout_ms_; }

 private:
  std::string camera_file_;
  std::optional<CameraIntrinsics> file_camera_;
  std::optional<double> file_readout_ms_;
  mutable std::atomic<bool> warned_{false};
};

}  // namespace dypho::ros_conversions
