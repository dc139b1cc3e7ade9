// Bag-side conversions: the nodelets' message conversions (dypho_ros_common) with the bag topic
// named in every error, plus the TUM bag conventions (rgb8 colour, 32FC1 depth with NaN holes).
#include "bag_conversions.h"

#include <cmath>
#include <cstdint>
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

void checkWritableEncodings(const std::string& colour_encoding, const std::string& depth_encoding) {
  namespace enc = sensor_msgs::image_encodings;
  if (colour_encoding != enc::RGB8 && colour_encoding != enc::BGR8) {
    throw std::invalid_argument("cannot write colour encoding '" + colour_encoding + "'; writable: rgb8, bgr8");
  }
  if (depth_encoding != enc::TYPE_32FC1 && depth_encoding != enc::TYPE_16UC1) {
    throw std::invalid_argument("cannot write depth encoding '" + depth_encoding +
                                "'; writable: 32FC1 (metres), 16UC1 (millimetres)");
  }
}

sensor_msgs::Image colourToMsg(const cv::Mat& bgr, const std_msgs::Header& header, const std::string& encoding) {
  namespace enc = sensor_msgs::image_encodings;
  if (bgr.type() != CV_8UC3) throw std::runtime_error("BagRgbdWriter: colour must be CV_8UC3 BGR");
  checkWritableEncodings(encoding, enc::TYPE_32FC1);
  if (encoding == enc::BGR8) return *rc::toImageMsg(bgr, enc::BGR8, header);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return *rc::toImageMsg(rgb, enc::RGB8, header);
}

cv::Mat depthToMillimetres(const cv::Mat& depth_m) {
  if (depth_m.type() != CV_32FC1) throw std::runtime_error("BagRgbdWriter: depth must be CV_32FC1 metres");
  cv::Mat mm(depth_m.size(), CV_16UC1);
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* z = depth_m.ptr<float>(r);
    std::uint16_t* out = mm.ptr<std::uint16_t>(r);
    for (int c = 0; c < depth_m.cols; ++c) {
      // In double, so that the product is not rounded to float before it is rounded to mm.
      const double v = std::round(static_cast<double>(z[c]) * 1000.0);
      const bool valid = std::isfinite(v) && v > 0.0 && v <= 65535.0;
      out[c] = valid ? static_cast<std::uint16_t>(v) : std::uint16_t{0};
    }
  }
  return mm;
}

sensor_msgs::Image depthToMsg(const cv::Mat& depth_m, const std_msgs::Header& header, const std::string& encoding) {
  namespace enc = sensor_msgs::image_encodings;
  if (depth_m.type() != CV_32FC1) throw std::runtime_error("BagRgbdWriter: depth must be CV_32FC1 metres");
  checkWritableEncodings(enc::RGB8, encoding);
  if (encoding == enc::TYPE_16UC1) return *rc::toImageMsg(depthToMillimetres(depth_m), enc::TYPE_16UC1, header);
  cv::Mat d = depth_m.clone();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  d.forEach<float>([nan](float& z, const int*) {
    if (!(z > 0.f) || !std::isfinite(z)) z = nan;
  });
  return *rc::toImageMsg(d, enc::TYPE_32FC1, header);
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
  return withTopic(topic, "; or pass --camera NAME_OR_YAML", [&] { return rc::toCameraIntrinsics(msg); });
}

}  // namespace dypho::tools::bag_detail
