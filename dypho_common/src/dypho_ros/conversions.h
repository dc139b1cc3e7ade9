#pragma once
/// \file conversions.h
/// The one place where ROS messages become core types and back (shared by the three nodelets).

#include <string>

#include <Eigen/Geometry>
#include <geometry_msgs/Pose.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/KeyframeCorrections.h>
#include <dypho_slam/TrackingStatus.h>

#include "dypho/common/motion_prior.h"
#include "dypho/common/types.h"

namespace dypho::ros_conversions {

/// Error in an input message; the text names the topic field, what was received and the fix.
class ConversionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Intrinsics from a CameraInfo (K, plumb_bob D). Throws ConversionError when K is all zero
/// (an uncalibrated camera) or the distortion model is not plumb_bob/rational_polynomial/empty.
CameraIntrinsics toCameraIntrinsics(const sensor_msgs::CameraInfo& info);

/// CameraInfo for intrinsics (K, P, plumb_bob D, identity R) with the given header.
sensor_msgs::CameraInfo toCameraInfoMsg(const CameraIntrinsics& camera, const std_msgs::Header& header);

/// Colour image (rgb8, bgr8, rgba8, bgra8, mono8) to CV_8UC3 BGR. Throws ConversionError otherwise.
cv::Mat toBgr(const sensor_msgs::Image& image);

/// Depth image (32FC1 metres, or 16UC1 millimetres as OpenNI/RealSense publish) to CV_32FC1 metres,
/// NaN/inf replaced by 0. Throws ConversionError for other encodings.
cv::Mat toDepthMetres(const sensor_msgs::Image& image);

/// Dynamic mask (mono8, 255 = dynamic) to CV_8UC1. Throws ConversionError for other encodings.
cv::Mat toMask(const sensor_msgs::Image& image);

/// Builds an RgbdFrame from synchronised messages; checks that the sizes agree with each other
/// and with the CameraInfo. Throws ConversionError with the mismatch.
RgbdFrame toRgbdFrame(const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth,
                      const sensor_msgs::CameraInfo& info);
/// As above, with the intrinsics given (FrameCamera::intrinsics: camera_info's or a camera file's).
RgbdFrame toRgbdFrame(const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth, const CameraIntrinsics& camera);

/// Image message sharing nothing with the input (deep copy) with the given encoding.
sensor_msgs::ImagePtr toImageMsg(const cv::Mat& image, const std::string& encoding, const std_msgs::Header& header);

/// Pose conversions.
geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& T);
/// Pose message to isometry (quaternion normalised). A zero or non-finite quaternion gives a
/// non-finite isometry (all NaN), which callers reject with allFinite().
Eigen::Isometry3d toIsometry(const geometry_msgs::Pose& pose);

/// Stamps.
Timestamp toTimestamp(const ros::Time& stamp);
ros::Time toRosTime(Timestamp stamp_ns);

/// Keyframe <-> message (images deep-copied).
dypho_slam::KeyframePtr toKeyframeMsg(const Keyframe& keyframe, const std::string& camera_frame);
/// Throws ConversionError for bad images or a pose with NaN.
Keyframe toKeyframe(const dypho_slam::Keyframe& msg);

/// The pose a TrackingStatus carries, as the stages' motion models take it.
PoseUpdate toPoseUpdate(const dypho_slam::TrackingStatus& status);

/// A correction batch as a message (poses that are not finite are left out).
dypho_slam::KeyframeCorrectionsPtr toCorrectionsMsg(const KeyframePoseCorrections& corrections,
                                                    const std_msgs::Header& header);

/// A correction batch from a message (poses that are not finite are left out).
KeyframePoseCorrections toCorrections(const dypho_slam::KeyframeCorrections& msg);

/// Moving points (tracking -> mask) as a cloud of float32 x, y, z in the camera optical frame
/// `header.frame_id`, stamped with the frame they were seen in.
sensor_msgs::PointCloud2Ptr toPointCloudMsg(const std::vector<cv::Point3f>& p_camera_m, const std_msgs::Header& header);
/// Moving points from such a cloud; points that are not finite are left out. Throws
/// ConversionError when the cloud has no float32 x, y and z fields.
MovingPoints toMovingPoints(const sensor_msgs::PointCloud2& cloud);

/// The folder services write into: `output_dir` when set, else $ROS_HOME/dypho (~/.ros/dypho).
std::string outputBaseDirectory(const std::string& output_dir);

/// The folder a nodelet writes its outputs into, created at start-up so that the save at shutdown
/// has somewhere to go: `output_dir` when set (a folder that cannot be created throws: a startup
/// error, not a silent loss at the end of the run), else outputBaseDirectory("") — there a
/// failure only fills `warning` (the outputs are lost unless ~output_dir is set).
std::string prepareOutputDirectory(const std::string& output_dir, std::string& warning);

}  // namespace dypho::ros_conversions
