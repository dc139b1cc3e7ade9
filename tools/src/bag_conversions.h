#pragma once
/// \file bag_conversions.h
/// Pure conversions between sensor_msgs and dypho core types (private to dypho_bag).

#include <string>

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "dypho/common/types.h"

namespace dypho::tools::bag_detail {

/// ros::Time of a non-negative ns stamp.
ros::Time toRosTime(Timestamp stamp_ns);
/// ns stamp of a ros::Time.
Timestamp fromRosTime(const ros::Time& t);

/// BGR CV_8UC3 -> `rgb8` (default) or `bgr8` image; another encoding throws std::invalid_argument.
sensor_msgs::Image colourToMsg(const cv::Mat& bgr, const std_msgs::Header& header,
                               const std::string& encoding = "rgb8");
/// CV_32FC1 metres -> `32FC1` image with invalid (0, NaN, negative) -> NaN (default), or -> `16UC1`
/// millimetres (depthToMillimetres); another encoding throws std::invalid_argument.
sensor_msgs::Image depthToMsg(const cv::Mat& depth_m, const std_msgs::Header& header,
                              const std::string& encoding = "32FC1");
/// CV_32FC1 metres -> CV_16UC1 millimetres rounded to nearest; no measurement (0, NaN, inf,
/// negative) and depth that does not fit (rounds above 65535 mm) -> 0, as RGB-D drivers publish.
cv::Mat depthToMillimetres(const cv::Mat& depth_m);
/// Throws std::invalid_argument unless colour/depth encodings can be written by the functions above.
void checkWritableEncodings(const std::string& colour_encoding, const std::string& depth_encoding);
/// plumb_bob CameraInfo with D, K, R = I, P.
sensor_msgs::CameraInfo cameraToMsg(const CameraIntrinsics& camera, const std_msgs::Header& header);

/// rgb8 / bgr8 / mono8 -> BGR CV_8UC3; other encodings throw naming `topic`.
cv::Mat colourFromMsg(const sensor_msgs::Image& msg, const std::string& topic);
/// 32FC1 [m] (NaN -> 0) / 16UC1 [mm] -> CV_32FC1 metres; other encodings throw naming `topic`.
cv::Mat depthFromMsg(const sensor_msgs::Image& msg, const std::string& topic);
/// Intrinsics from K (and D when the model is plumb_bob / rational_polynomial, first 5).
CameraIntrinsics cameraFromMsg(const sensor_msgs::CameraInfo& msg, const std::string& topic);

}  // namespace dypho::tools::bag_detail
