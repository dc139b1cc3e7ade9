#include "dypho_ros/frame_camera.h"

#include <algorithm>
#include <sstream>

#include "dypho/tools/camera_config.h"
#include "dypho_ros/conversions.h"

namespace dypho::ros_conversions {

bool looksLikeNominalCalibration(const sensor_msgs::CameraInfo& info) {
  const bool no_distortion = std::all_of(info.D.begin(), info.D.end(), [](double d) { return d == 0.0; });
  const bool centred = info.K[2] == 0.5 * (static_cast<double>(info.width) - 1.0) &&
                       info.K[5] == 0.5 * (static_cast<double>(info.height) - 1.0);
  return no_distortion && centred && info.K[0] == info.K[4] && info.K[0] > 0.0;
}

FrameCamera::FrameCamera(const std::string& camera_file) : camera_file_(camera_file) {
  if (camera_file.empty()) return;
  const tools::CameraConfig config = tools::loadCameraConfig(camera_file);
  file_camera_ = config.camera;
  file_readout_ms_ = config.rolling_shutter_readout_ms;
}

CameraIntrinsics FrameCamera::intrinsics(const sensor_msgs::CameraInfo& info, std::string* warning_once) const {
  if (file_camera_) {
    const CameraIntrinsics& c = *file_camera_;
    if (static_cast<int>(info.width) != c.width || static_cast<int>(info.height) != c.height) {
      throw ConversionError("camera_file " + camera_file_ + " is for " + std::to_string(c.width) + "x" +
                            std::to_string(c.height) + " images but camera_info says " + std::to_string(info.width) +
                            "x" + std::to_string(info.height) + ": give the camera file of this camera");
    }
    return c;
  }
  CameraIntrinsics camera = toCameraIntrinsics(info);
  if (warning_once != nullptr && looksLikeNominalCalibration(info) && !warned_.exchange(true)) {
    std::ostringstream text;
    text << "camera_info holds nominal values, not a calibration (fx = fy = " << info.K[0]
         << " px, principal point at the image centre, no distortion), as uncalibrated OpenNI drivers "
            "and TUM's published bags publish them; poses are less accurate with them. Give the "
            "camera's calibration with the launch argument camera_file:=FILE (config/cameras/*.yaml)";
    *warning_once = text.str();
  }
  return camera;
}

std::string FrameCamera::describe() const {
  if (!file_camera_) return "intrinsics from each frame's camera_info";
  const CameraIntrinsics& c = *file_camera_;
  std::ostringstream text;
  text << "intrinsics from camera_file " << camera_file_ << " (" << c.width << "x" << c.height << ", fx " << c.fx
       << ", fy " << c.fy << ", cx " << c.cx << ", cy " << c.cy << "), not from camera_info";
  return text.str();
}

}  // namespace dypho::ros_conversions
