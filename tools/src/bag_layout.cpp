// Topic layouts of the RGB-D drivers whose bags BagRgbdWriter writes (TUM benchmark, RealSense,
// OpenNI2).
#include <stdexcept>

#include "dypho/tools/bag_io.h"

namespace dypho::tools {

BagLayout parseBagLayout(const std::string& name) {
  if (name == "tum") return BagLayout::kTum;
  if (name == "realsense") return BagLayout::kRealSense;
  if (name == "openni") return BagLayout::kOpenNi;
  throw std::invalid_argument("unknown bag layout '" + name + "'; accepted: tum, realsense, openni");
}

std::string bagLayoutName(BagLayout layout) {
  switch (layout) {
    case BagLayout::kTum:
      return "tum";
    case BagLayout::kRealSense:
      return "realsense";
    case BagLayout::kOpenNi:
      return "openni";
  }
  throw std::invalid_argument("bagLayoutName: not a BagLayout value");
}

BagTopics bagTopicsFor(BagLayout layout) {
  BagTopics t;  // the TUM defaults
  switch (layout) {
    case BagLayout::kTum:
      break;
    case BagLayout::kRealSense:  // realsense2_camera rs_camera.launch align_depth:=true
      t.rgb = "/camera/color/image_raw";
      t.depth = "/camera/aligned_depth_to_color/image_raw";
      t.camera_info = "/camera/color/camera_info";
      t.frame_id = "camera_color_optical_frame";
      t.colour_encoding = "rgb8";
      t.depth_encoding = "16UC1";
      break;
    case BagLayout::kOpenNi:  // openni2_launch openni2.launch depth_registration:=true
      t.rgb = "/camera/rgb/image_rect_color";
      t.depth = "/camera/depth_registered/image_raw";
      t.camera_info = "/camera/rgb/camera_info";
      t.frame_id = "camera_rgb_optical_frame";
      t.colour_encoding = "rgb8";
      t.depth_encoding = "16UC1";
      break;
  }
  return t;
}

}  // namespace dypho::tools
