/// FrameCamera: a camera file's intrinsics replace a CameraInfo's; nominal CameraInfos (TUM's
/// bags) are recognised; bad files and mismatched sizes are clear errors. No roscore needed.
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "dypho/tools/camera_config.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/frame_camera.h"

namespace DYPHO_UNITY_ID {

namespace rc = dypho::ros_conversions;

const std::string kFr1File = std::string(DYPHO_SOURCE_DIR) + "/config/cameras/tum_fr1.yaml";

/// What the OpenNI driver publishes for an uncalibrated Kinect, and what TUM's bags carry.
sensor_msgs::CameraInfo nominalKinectInfo() {
  sensor_msgs::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info.distortion_model = "plumb_bob";
  info.D = {0.0, 0.0, 0.0, 0.0, 0.0};
  info.K = {525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0};
  return info;
}

TEST(FrameCamera, ACameraFileReplacesTheCameraInfo) {
  const rc::FrameCamera camera(kFr1File);
  std::string warning;
  const dypho::CameraIntrinsics c = camera.intrinsics(nominalKinectInfo(), &warning);
  const dypho::CameraIntrinsics expected = dypho::tools::loadCameraConfig(kFr1File).camera;
  EXPECT_TRUE(dypho::sameCamera(c, expected));
  EXPECT_DOUBLE_EQ(c.fx, expected.fx);
  EXPECT_NE(c.fx, 525.0);
  EXPECT_NE(c.distortion[0], 0.0);  // fr1's lens distortion comes with the file
  EXPECT_TRUE(warning.empty()) << "the file is the calibration: nothing to warn about";
  EXPECT_NE(camera.describe().find(kFr1File), std::string::npos);
  ASSERT_TRUE(camera.rollingShutterReadoutMs().has_value());
  EXPECT_DOUBLE_EQ(*camera.rollingShutterReadoutMs(),
                   dypho::tools::loadCameraConfig(kFr1File).rolling_shutter_readout_ms);
  EXPECT_FALSE(rc::FrameCamera("").rollingShutterReadoutMs().has_value());
}

TEST(FrameCamera, WithoutAFileTheCameraInfoIsTakenAndNominalValuesWarnOnce) {
  const rc::FrameCamera camera("");
  std::string first, second;
  const dypho::CameraIntrinsics c = camera.intrinsics(nominalKinectInfo(), &first);
  EXPECT_DOUBLE_EQ(c.fx, 525.0);
  EXPECT_DOUBLE_EQ(c.cy, 239.5);
  EXPECT_NE(first.find("camera_file"), std::string::npos) << first;
  camera.intrinsics(nominalKinectInfo(), &second);
  EXPECT_TRUE(second.empty()) << "warned twice: " << second;
}

TEST(FrameCamera, NominalValuesAreToldFromACalibration) {
  EXPECT_TRUE(rc::looksLikeNominalCalibration(nominalKinectInfo()));
  sensor_msgs::CameraInfo calibrated = nominalKinectInfo();
  calibrated.K[2] = 318.6;  // a calibrated principal point
  EXPECT_FALSE(rc::looksLikeNominalCalibration(calibrated));
  calibrated = nominalKinectInfo();
  calibrated.D[0] = 0.26;  // a calibrated lens
  EXPECT_FALSE(rc::looksLikeNominalCalibration(calibrated));
  calibrated = nominalKinectInfo();
  calibrated.K[4] = 516.5;  // fx != fy
  EXPECT_FALSE(rc::looksLikeNominalCalibration(calibrated));

  const rc::FrameCamera camera("");
  std::string warning;
  camera.intrinsics(calibrated, &warning);
  EXPECT_TRUE(warning.empty()) << warning;
}

TEST(FrameCamera, AFileForAnotherImageSizeIsAClearError) {
  const rc::FrameCamera camera(kFr1File);
  sensor_msgs::CameraInfo half = nominalKinectInfo();
  half.width = 320;
  half.height = 240;
  try {
    camera.intrinsics(half);
    FAIL() << "a 640x480 camera file was taken for 320x240 images";
  } catch (const rc::ConversionError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("640x480"), std::string::npos) << what;
    EXPECT_NE(what.find("320x240"), std::string::npos) << what;
  }
}

TEST(FrameCamera, AMissingOrBrokenFileFailsAtStartNamingIt) {
  const std::string missing = "/nonexistent/dypho_camera.yaml";
  try {
    rc::FrameCamera camera(missing);
    FAIL() << "a missing camera file was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  const std::string broken = ::testing::TempDir() + "dypho_broken_camera.yaml";
  std::ofstream(broken) << "name: broken\nwidth: 640\nheight: 480\nfx: -1\n";
  EXPECT_THROW(rc::FrameCamera camera(broken), std::runtime_error);
}

}  // namespace DYPHO_UNITY_ID
