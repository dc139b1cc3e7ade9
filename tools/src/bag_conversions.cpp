// Bag-side conversions: the nodelets' message conversions (dypho_ros_common) with the bag topic
// named in every error, plus the TUM bag conventions (rgb8 colour, 32FC1 depth with NaN holes).
#include "bag_conversions.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <sensor_msgs/image_encodings.h>

#include "dypho_ros/conversions.h"

namespace dypho::tools::bag_detail {
namespace rc = dypho::ros_conversions;
namespace {

/// Runs `convert`, prefixing a conversion error with the topic and appending `fix`.
template <typename F>
auto withTopic(const std::string& topic, const std::string& fix, F&& convert) {
  try {
    return convert();
  } catch (const std::exception& e) {
    throw std::runtime_error("topic '" + topic + "': " + e.what() + fix);
  }
}

}  // namespace

ros::Time toRosTime(Timestamp stamp_ns) {
  if (stamp_ns < 0) throw std::runtime_error("negative timestamp cannot be written to a bag");
  return rc::toRosTime(stamp_ns);
}

Timestamp fromRosTime(const ros::Time& t) { return rc::toTimestamp(t); }

sensor_msgs::Image colourToMsg(const cv::Mat& bgr, const std_msgs::Header& header) {
  if (bgr.type() != CV_8UC3) throw std::runtime_error("BagRgbdWriter: colour must be CV_8UC3 BGR");
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return *rc::toImageMsg(rgb, sensor_msgs::image_encodings::RGB8, header);
}

sensor_msgs::Image depthToMsg(const cv::Mat& depth_m, const std_msgs::Header& header) {
  if (depth_m.type() != CV_32FC1) throw std::runtime_error("BagRgbdWriter: depth must be CV_32FC1 metres");
  cv::Mat d = depth_m.clone();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  d.forEach<float>([nan](float& z, const int*) { if (!(z > 0.f) || !std::isfinite(z)) z = nan; });
  return *rc::toImageMsg(d, sensor_msgs::image_encodings::TYPE_32FC1, header);
}

sensor_msgs::CameraInfo cameraToMsg(const CameraIntrinsics& c, const std_msgs::Header& header) {
  return rc::toCameraInfoMsg(c, header);
}

cv::Mat colourFromMsg(const sensor_msgs::Image& msg, const std::string& topic) {
  return withTopic(topic, "", [&] { return rc::toBgr(msg); });
}

cv::Mat depthFromMsg(const sensor_msgs::Image& msg, const std::string& topic) {
  return withTopic(topic, "", [&] { return rc::toDepthMetres(msg); });
}

CameraIntrinsics cameraFromMsg(const sensor_msgs::CameraInfo& msg, const std::string& topic) {
  return withTopic(topic, "; or pass --camera NAME_OR_YAML",
                   [&] { return rc::toCameraIntrinsics(msg); });
}

}  // namespace dypho::tools::bag_detail
