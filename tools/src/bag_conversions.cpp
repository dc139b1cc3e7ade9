// Conversions between sensor_msgs and dypho core types, written by hand (no cv_bridge).
#include "bag_conversions.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace dypho::tools::bag_detail {
namespace {

/// Wraps the message bytes as a Mat (no copy) after checking size, step and byte order.
cv::Mat wrap(const sensor_msgs::Image& msg, int type, const std::string& topic) {
  const std::size_t row_bytes = static_cast<std::size_t>(msg.width) * CV_ELEM_SIZE(type);
  if (msg.width == 0 || msg.height == 0 || msg.step < row_bytes ||
      msg.data.size() < static_cast<std::size_t>(msg.step) * msg.height) {
    throw std::runtime_error("topic '" + topic + "': malformed image (" + std::to_string(msg.width) + "x" +
                             std::to_string(msg.height) + ", step " + std::to_string(msg.step) + ", " +
                             std::to_string(msg.data.size()) + " bytes)");
  }
  if (msg.is_bigendian && CV_ELEM_SIZE1(type) > 1) {
    throw std::runtime_error("topic '" + topic + "': big-endian " + msg.encoding +
                             " images are not supported; re-record on a little-endian machine");
  }
  return cv::Mat(static_cast<int>(msg.height), static_cast<int>(msg.width), type,
                 const_cast<std::uint8_t*>(msg.data.data()), msg.step);
}

sensor_msgs::Image makeImage(const cv::Mat& m, const std::string& encoding, const std_msgs::Header& header) {
  sensor_msgs::Image msg;
  msg.header = header;
  msg.height = static_cast<std::uint32_t>(m.rows);
  msg.width = static_cast<std::uint32_t>(m.cols);
  msg.encoding = encoding;
  msg.is_bigendian = 0;
  msg.step = static_cast<std::uint32_t>(m.cols * m.elemSize());
  msg.data.resize(static_cast<std::size_t>(msg.step) * m.rows);
  for (int v = 0; v < m.rows; ++v) std::memcpy(&msg.data[static_cast<std::size_t>(v) * msg.step], m.ptr(v), msg.step);
  return msg;
}

}  // namespace

ros::Time toRosTime(Timestamp stamp_ns) {
  if (stamp_ns < 0) throw std::runtime_error("negative timestamp cannot be written to a bag");
  ros::Time t;
  t.sec = static_cast<std::uint32_t>(stamp_ns / 1000000000);
  t.nsec = static_cast<std::uint32_t>(stamp_ns % 1000000000);
  return t;
}

Timestamp fromRosTime(const ros::Time& t) {
  return static_cast<Timestamp>(t.sec) * 1000000000 + static_cast<Timestamp>(t.nsec);
}

sensor_msgs::Image colourToMsg(const cv::Mat& bgr, const std_msgs::Header& header) {
  if (bgr.type() != CV_8UC3) throw std::runtime_error("BagRgbdWriter: colour must be CV_8UC3 BGR");
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return makeImage(rgb, "rgb8", header);
}

sensor_msgs::Image depthToMsg(const cv::Mat& depth_m, const std_msgs::Header& header) {
  if (depth_m.type() != CV_32FC1) throw std::runtime_error("BagRgbdWriter: depth must be CV_32FC1 metres");
  cv::Mat d = depth_m.clone();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  d.forEach<float>([nan](float& z, const int*) { if (!(z > 0.f) || !std::isfinite(z)) z = nan; });
  return makeImage(d, "32FC1", header);
}

sensor_msgs::CameraInfo cameraToMsg(const CameraIntrinsics& c, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo msg;
  msg.header = header;
  msg.width = static_cast<std::uint32_t>(c.width);
  msg.height = static_cast<std::uint32_t>(c.height);
  msg.distortion_model = "plumb_bob";
  msg.D.assign(c.distortion.begin(), c.distortion.end());
  msg.K = {c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0};
  msg.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  msg.P = {c.fx, 0.0, c.cx, 0.0, 0.0, c.fy, c.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return msg;
}

cv::Mat colourFromMsg(const sensor_msgs::Image& msg, const std::string& topic) {
  cv::Mat bgr;
  if (msg.encoding == "rgb8") {
    cv::cvtColor(wrap(msg, CV_8UC3, topic), bgr, cv::COLOR_RGB2BGR);
  } else if (msg.encoding == "bgr8") {
    bgr = wrap(msg, CV_8UC3, topic).clone();
  } else if (msg.encoding == "mono8") {
    cv::cvtColor(wrap(msg, CV_8UC1, topic), bgr, cv::COLOR_GRAY2BGR);
  } else {
    throw std::runtime_error("topic '" + topic + "' has colour encoding '" + msg.encoding +
                             "'; accepted colour encodings: rgb8, bgr8, mono8 (convert the bag or "
                             "pass the right topic)");
  }
  return bgr;
}

cv::Mat depthFromMsg(const sensor_msgs::Image& msg, const std::string& topic) {
  cv::Mat depth_m;
  if (msg.encoding == "32FC1") {
    depth_m = wrap(msg, CV_32FC1, topic).clone();
    depth_m.forEach<float>([](float& z, const int*) { if (!std::isfinite(z) || z < 0.f) z = 0.f; });
  } else if (msg.encoding == "16UC1" || msg.encoding == "mono16") {
    wrap(msg, CV_16UC1, topic).convertTo(depth_m, CV_32FC1, 1.0 / 1000.0);  // OpenNI: millimetres
  } else {
    throw std::runtime_error("topic '" + topic + "' has depth encoding '" + msg.encoding +
                             "'; accepted depth encodings: 32FC1 (metres), 16UC1 (millimetres)");
  }
  return depth_m;
}

CameraIntrinsics cameraFromMsg(const sensor_msgs::CameraInfo& msg, const std::string& topic) {
  CameraIntrinsics c;
  c.fx = msg.K[0];
  c.fy = msg.K[4];
  c.cx = msg.K[2];
  c.cy = msg.K[5];
  c.width = static_cast<int>(msg.width);
  c.height = static_cast<int>(msg.height);
  if ((msg.distortion_model == "plumb_bob" || msg.distortion_model == "rational_polynomial") && !msg.D.empty()) {
    for (std::size_t k = 0; k < 5 && k < msg.D.size(); ++k) c.distortion[k] = msg.D[k];
  } else if (!msg.D.empty() && msg.distortion_model != "" ) {
    throw std::runtime_error("topic '" + topic + "': distortion model '" + msg.distortion_model +
                             "' is not supported (plumb_bob only); pass --camera NAME_OR_YAML");
  }
  if (!c.valid()) {
    throw std::runtime_error("topic '" + topic + "': CameraInfo has no valid K/size (fx=" + std::to_string(c.fx) +
                             ", " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                             "); pass --camera NAME_OR_YAML");
  }
  return c;
}

}  // namespace dypho::tools::bag_detail
