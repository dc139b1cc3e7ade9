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

/// BGR CV_8UC3 -> `rgb8` image.
sensor_msgs::Image colourToMsg(const cv::Mat& bgr, const std_msgs::Header& header);
/// CV_32FC1 metres -> `32FC1` image, invalid (0, NaN, negative) -> NaN.
sensor_msgs::Image depthToMsg(const cv::Mat& depth_m, const std_msgs::Header& header);
/// plumb_bob CameraInfo with D, K, R = I, P.
sensor_msgs::CameraInfo cameraToMsg(const CameraIntrinsics& camera, const std_msgs::Header& header);

/// rgb8 / bgr8 / mono8 -> BGR CV_8UC3; other encodings throw naming `topic`.
cv::Mat colourFromMsg(const sensor_msgs::Image& msg, const std::string& topic);
/// 32FC1 [m] (NaN -> 0) / 16UC1 [mm] -> CV_32FC1 metres; other encodings throw naming `topic`.
cv::Mat depthFromMsg(const sensor_msgs::Image& msg, const std::string& topic);
/// Intrinsics from K (and D when the model is plumb_bob / rational_polynomial, first 5).
CameraIntrinsics cameraFromMsg(const sensor_msgs::CameraInfo& msg, const std::string& topic);

}  // namespace dypho::tools::bag_detail
