#include "dypho_ros/conversions.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include <boost/make_shared.hpp>
#include <cv_bridge/cv_bridge.h>
#include <opencv2/imgproc.hpp>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>

namespace dypho::ros_conversions {
namespace enc = sensor_msgs::image_encodings;

CameraIntrinsics toCameraIntrinsics(const sensor_msgs::CameraInfo& info) {
  CameraIntrinsics camera;
  camera.fx = info.K[0];
  camera.fy = info.K[4];
  camera.cx = info.K[2];
  camera.cy = info.K[5];
  camera.width = static_cast<int>(info.width);
  camera.height = static_cast<int>(info.height);
  if (!camera.valid()) {
    throw ConversionError("camera_info has no calibration (K = [" + std::to_string(info.K[0]) + ", ...], size " +
                          std::to_string(info.width) + "x" + std::to_string(info.height) +
                          "): calibrate the camera or publish a CameraInfo with K, width and height set");
  }
  const std::string& model = info.distortion_model;
  if (!model.empty() && model != "plumb_bob" && model != "rational_polynomial") {
    throw ConversionError("camera_info distortion_model '" + model +
                          "' is not supported (use plumb_bob, or publish rectified images)");
  }
  // plumb_bob has k1 k2 p1 p2 k3; rational_polynomial adds k4 k5 k6, which the cores do not model:
  // accepted only when they are zero (then it is plumb_bob), never cut off silently.
  for (std::size_t i = camera.distortion.size(); i < info.D.size(); ++i) {
    if (info.D[i] != 0.0) {
      throw ConversionError("camera_info distortion_model '" + model + "' has D[" + std::to_string(i) +
                            "] = " + std::to_string(info.D[i]) +
                            "; only the plumb_bob coefficients k1 k2 p1 p2 k3 are "
                            "supported: publish rectified images (image_proc) or a plumb_bob calibration");
    }
  }
  for (std::size_t i = 0; i < info.D.size() && i < camera.distortion.size(); ++i) {
    camera.distortion[i] = info.D[i];
  }
  return camera;
}

sensor_msgs::CameraInfo toCameraInfoMsg(const CameraIntrinsics& camera, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<std::uint32_t>(camera.width);
  info.height = static_cast<std::uint32_t>(camera.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(camera.distortion.begin(), camera.distortion.end());
  info.K = {camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {camera.fx, 0.0, camera.cx, 0.0, 0.0, camera.fy, camera.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

cv::Mat toBgr(const sensor_msgs::Image& image) {
  const std::string& e = image.encoding;
  if (e != enc::RGB8 && e != enc::BGR8 && e != enc::RGBA8 && e != enc::BGRA8 && e != enc::MONO8) {
    throw ConversionError("colour image has encoding '" + e +
                          "'; accepted: rgb8, bgr8, rgba8, bgra8, mono8 (check the rgb topic remap)");
  }
  return cv_bridge::toCvCopy(image, enc::BGR8)->image;
}

cv::Mat toDepthMetres(const sensor_msgs::Image& image) {
  cv::Mat depth_m;
  if (image.encoding == enc::TYPE_32FC1) {
    depth_m = cv_bridge::toCvCopy(image, enc::TYPE_32FC1)->image;
  } else if (image.encoding == enc::TYPE_16UC1 || image.encoding == enc::MONO16) {
    cv_bridge::toCvShare(image, nullptr, enc::TYPE_16UC1)->image.convertTo(depth_m, CV_32F, 1e-3);
  } else {
    throw ConversionError("depth image has encoding '" + image.encoding +
                          "'; accepted: 32FC1 (metres) or 16UC1 (millimetres). Is the depth topic "
                          "remapped to a colour image?");
  }
  // NaN / inf / negative mean "no measurement": store them as 0. A plain loop over the rows:
  // cv::Mat::forEach computed each pixel's position for a lambda that does not use it, 2 % of
  // the mask and feature threads' samples live.
  for (int y = 0; y < depth_m.rows; ++y) {
    float* d = depth_m.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      if (!std::isfinite(d[x]) || d[x] < 0.f) d[x] = 0.f;
    }
  }
  return depth_m;
}

cv::Mat toMask(const sensor_msgs::Image& image) {
  if (image.encoding != enc::MONO8 && image.encoding != enc::TYPE_8UC1) {
    throw ConversionError("mask has encoding '" + image.encoding + "'; expected mono8 with 255 = dynamic, 0 = static");
  }
  return cv_bridge::toCvCopy(image, enc::MONO8)->image;
}

RgbdFrame toRgbdFrame(const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth, const CameraIntrinsics& camera) {
  RgbdFrame frame;
  frame.stamp_ns = toTimestamp(rgb.header.stamp);
  frame.camera = camera;
  frame.bgr = toBgr(rgb);
  frame.depth_m = toDepthMetres(depth);
  if (frame.bgr.size() != frame.depth_m.size()) {
    throw ConversionError("rgb is " + std::to_string(rgb.width) + "x" + std::to_string(rgb.height) + " but depth is " +
                          std::to_string(depth.width) + "x" + std::to_string(depth.height) +
                          ": use a depth image registered to the colour camera");
  }
  if (frame.bgr.cols != frame.camera.width || frame.bgr.rows != frame.camera.height) {
    throw ConversionError("camera_info says " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                          " but the images are " + std::to_string(rgb.width) + "x" + std::to_string(rgb.height) +
                          ": the camera_info topic does not belong to this image");
  }
  return frame;
}

RgbdFrame toRgbdFrame(const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth,
                      const sensor_msgs::CameraInfo& info) {
  return toRgbdFrame(rgb, depth, toCameraIntrinsics(info));
}

sensor_msgs::ImagePtr toImageMsg(const cv::Mat& image, const std::string& encoding, const std_msgs::Header& header) {
  return cv_bridge::CvImage(header, encoding, image).toImageMsg();  // one copy, into the message
}

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& T) {
  geometry_msgs::Pose pose;
  const Eigen::Quaterniond q(T.rotation());
  pose.position.x = T.translation().x();
  pose.position.y = T.translation().y();
  pose.position.z = T.translation().z();
  pose.orientation.x = q.x();
  pose.orientation.y = q.y();
  pose.orientation.z = q.z();
  pose.orientation.w = q.w();
  return pose;
}

Eigen::Isometry3d toIsometry(const geometry_msgs::Pose& pose) {
  Eigen::Quaterniond q(pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (!(q.norm() > 1e-9)) {
    // A zero (or NaN) quaternion is no rotation: the pose is marked non-finite, which every
    // caller rejects, instead of silently becoming identity.
    T.matrix().setConstant(std::numeric_limits<double>::quiet_NaN());
    return T;
  }
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  return T;
}

Timestamp toTimestamp(const ros::Time& stamp) { return static_cast<Timestamp>(stamp.toNSec()); }

ros::Time toRosTime(Timestamp stamp_ns) {
  ros::Time t;
  t.fromNSec(static_cast<std::uint64_t>(stamp_ns < 0 ? 0 : stamp_ns));
  return t;
}

dypho_slam::KeyframePtr toKeyframeMsg(const Keyframe& keyframe, const std::string& camera_frame) {
  auto msg = boost::make_shared<dypho_slam::Keyframe>();
  std_msgs::Header header;
  header.stamp = toRosTime(keyframe.frame.stamp_ns);
  header.frame_id = camera_frame;
  msg->header = header;
  msg->id = keyframe.id;
  // Each image is copied once, straight into the message's buffer.
  cv_bridge::CvImage(header, enc::BGR8, keyframe.frame.bgr).toImageMsg(msg->rgb);
  cv_bridge::CvImage(header, enc::TYPE_32FC1, keyframe.frame.depth_m).toImageMsg(msg->depth);
  const cv::Mat mask =
      keyframe.mask.empty() ? cv::Mat(keyframe.frame.bgr.size(), CV_8UC1, cv::Scalar(kMaskStatic)) : keyframe.mask;
  cv_bridge::CvImage(header, enc::MONO8, mask).toImageMsg(msg->mask);
  msg->camera_info = toCameraInfoMsg(keyframe.frame.camera, header);
  msg->T_world_camera = toPoseMsg(keyframe.T_world_camera);
  msg->keypoints.reserve(keyframe.keypoints.size());
  for (const KeyframeKeypoint& kp : keyframe.keypoints) {
    dypho_slam::KeyframeKeypoint k;
    k.u = kp.u_px;
    k.v = kp.v_px;
    k.depth = kp.depth_m;
    k.map_point_id = kp.map_point_id;
    msg->keypoints.push_back(k);
  }
  return msg;
}

Keyframe toKeyframe(const dypho_slam::Keyframe& msg) {
  Keyframe keyframe;
  keyframe.id = msg.id;
  keyframe.frame = toRgbdFrame(msg.rgb, msg.depth, msg.camera_info);
  keyframe.mask = toMask(msg.mask);
  keyframe.T_world_camera = toIsometry(msg.T_world_camera);
  if (!keyframe.T_world_camera.matrix().allFinite()) {
    throw ConversionError("keyframe " + std::to_string(msg.id) + " has a non-finite pose");
  }
  keyframe.keypoints.reserve(msg.keypoints.size());
  for (const auto& k : msg.keypoints) {
    keyframe.keypoints.push_back({k.u, k.v, k.depth, k.map_point_id});
  }
  return keyframe;
}

PoseUpdate toPoseUpdate(const dypho_slam::TrackingStatus& status) {
  PoseUpdate update;
  update.stamp_ns = toTimestamp(status.header.stamp);
  update.T_world_camera = toIsometry(status.T_world_camera);
  update.trusted = status.trusted && update.T_world_camera.matrix().allFinite();
  update.anchored = status.anchored;
  update.discontinuous = status.discontinuous || status.restarted;
  update.restarted = status.restarted;
  const Eigen::Isometry3d T_correction = toIsometry(status.T_correction);
  // A message without the field (all zeros: no valid rotation) or a broken one: no correction.
  const bool valid = T_correction.matrix().allFinite() && std::abs(T_correction.linear().determinant() - 1.0) < 1e-3;
  update.T_correction = valid ? T_correction : Eigen::Isometry3d::Identity();
  return update;
}

dypho_slam::KeyframeCorrectionsPtr toCorrectionsMsg(const KeyframePoseCorrections& corrections,
                                                    const std_msgs::Header& header) {
  auto msg = boost::make_shared<dypho_slam::KeyframeCorrections>();
  msg->header = header;
  for (const auto& [id, T_world_camera] : corrections) {
    if (!T_world_camera.matrix().allFinite()) continue;
    dypho_slam::KeyframePose pose;
    pose.header = header;
    pose.id = id;
    pose.T_world_camera = toPoseMsg(T_world_camera);
    msg->poses.push_back(pose);
  }
  return msg;
}

KeyframePoseCorrections toCorrections(const dypho_slam::KeyframeCorrections& msg) {
  KeyframePoseCorrections corrections;
  for (const auto& pose : msg.poses) {
    const Eigen::Isometry3d T = toIsometry(pose.T_world_camera);
    if (T.matrix().allFinite()) corrections.emplace_back(pose.id, T);
  }
  return corrections;
}

sensor_msgs::PointCloud2Ptr toPointCloudMsg(const std::vector<cv::Point3f>& p_camera_m,
                                            const std_msgs::Header& header) {
  auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
  msg->header = header;
  sensor_msgs::PointCloud2Modifier modifier(*msg);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(p_camera_m.size());
  sensor_msgs::PointCloud2Iterator<float> x(*msg, "x"), y(*msg, "y"), z(*msg, "z");
  for (const cv::Point3f& p : p_camera_m) {
    *x = p.x;
    *y = p.y;
    *z = p.z;
    ++x, ++y, ++z;
  }
  return msg;
}

MovingPoints toMovingPoints(const sensor_msgs::PointCloud2& cloud) {
  for (const char* name : {"x", "y", "z"}) {
    bool found = false;
    for (const sensor_msgs::PointField& f : cloud.fields) {
      found = found || (f.name == name && f.datatype == sensor_msgs::PointField::FLOAT32 && f.count == 1);
    }
    if (!found) throw ConversionError(std::string("moving points cloud has no float32 field '") + name + "'");
  }
  if (cloud.data.size() < static_cast<std::size_t>(cloud.row_step) * cloud.height ||
      static_cast<std::size_t>(cloud.point_step) * cloud.width > cloud.row_step) {
    throw ConversionError("moving points cloud: data shorter than its width, height and steps say");
  }
  MovingPoints points;
  points.stamp_ns = toTimestamp(cloud.header.stamp);
  sensor_msgs::PointCloud2ConstIterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (; x != x.end(); ++x, ++y, ++z) {
    if (std::isfinite(*x) && std::isfinite(*y) && std::isfinite(*z)) points.p_camera_m.emplace_back(*x, *y, *z);
  }
  return points;
}

std::string outputBaseDirectory(const std::string& output_dir) {
  if (!output_dir.empty()) return output_dir;
  const char* ros_home = std::getenv("ROS_HOME");
  if (ros_home != nullptr && *ros_home != '\0') return std::string(ros_home) + "/dypho";
  const char* home = std::getenv("HOME");
  return std::string(home != nullptr ? home : ".") + "/.ros/dypho";
}

std::string prepareOutputDirectory(const std::string& output_dir, std::string& warning) {
  warning.clear();
  if (!output_dir.empty()) {
    std::filesystem::create_directories(output_dir);
    return output_dir;
  }
  const std::string dir = outputBaseDirectory(output_dir);
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) warning = "cannot create the default output folder " + dir + " (" + error.message() + ")";
  return dir;
}

}  // namespace dypho::ros_conversions
