#pragma once
/// \file bag_io.h
/// RGB-D frames to and from ROS 1 bags in the TUM RGB-D topic layout or a live driver's layout
/// (RealSense, OpenNI2; library dypho_bag, ROS).
/// The header itself has no ROS types; the implementation uses rosbag and sensor_msgs.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dypho/common/types.h"

namespace dypho::tools {

/// Topic names (defaults = the TUM RGB-D benchmark bags), the optical frame id and the encodings
/// BagRgbdWriter writes (BagRgbdReader accepts every supported encoding whatever these say).
struct BagTopics {
  std::string rgb = "/camera/rgb/image_color";          ///< sensor_msgs/Image, colour
  std::string depth = "/camera/depth/image";            ///< sensor_msgs/Image, registered depth
  std::string camera_info = "/camera/rgb/camera_info";  ///< sensor_msgs/CameraInfo of the colour image
  std::string frame_id = "openni_rgb_optical_frame";    ///< header.frame_id written by BagRgbdWriter
  std::string colour_encoding = "rgb8";                 ///< written colour encoding: `rgb8` or `bgr8`
  /// written depth encoding: `32FC1` (metres, NaN = no measurement) or `16UC1` (millimetres
  /// rounded to nearest, 0 = no measurement, as RealSense and OpenNI drivers publish)
  std::string depth_encoding = "32FC1";
};

/// Topic layouts of the bags BagRgbdWriter can write.
enum class BagLayout {
  /// TUM RGB-D benchmark bags: /camera/rgb/image_color (rgb8), /camera/depth/image (32FC1 m),
  /// /camera/rgb/camera_info, frame openni_rgb_optical_frame.
  kTum,
  /// realsense2_camera with align_depth: /camera/color/image_raw (rgb8),
  /// /camera/aligned_depth_to_color/image_raw (16UC1 mm), /camera/color/camera_info, frame
  /// camera_color_optical_frame.
  kRealSense,
  /// openni2_launch with depth_registration: /camera/rgb/image_rect_color (rgb8, as openni2_camera
  /// publishes), /camera/depth_registered/image_raw (16UC1 mm), /camera/rgb/camera_info, frame
  /// camera_rgb_optical_frame.
  kOpenNi,
};

/// "tum" | "realsense" | "openni" -> BagLayout; anything else throws std::invalid_argument naming
/// the accepted names.
BagLayout parseBagLayout(const std::string& name);
/// The name parseBagLayout() accepts for `layout`.
std::string bagLayoutName(BagLayout layout);
/// Topics, frame id and encodings of `layout`.
BagTopics bagTopicsFor(BagLayout layout);

/// Writes RgbdFrames with the encodings of `topics`: colour as `rgb8` (default) or `bgr8`; depth as
/// `32FC1` metres with invalid depth (0, NaN, negative) written as NaN (as in the TUM bags), or as
/// `16UC1` millimetres rounded to the nearest millimetre with invalid depth, and depth that
/// does not fit in 16 bits (>= 65.5355 m), written as 0 (as RealSense and OpenNI publish); and a
/// `plumb_bob` CameraInfo (D = the 5 distortion coefficients, K, R = I, P) per frame. Header stamps
/// = frame stamps, the bag time = the header stamp.
class BagRgbdWriter {
 public:
  /// Creates (overwrites) the bag at `path`. Throws std::runtime_error naming the path when it
  /// cannot be created (missing folder, permissions), std::invalid_argument for an encoding in
  /// `topics` it cannot write.
  explicit BagRgbdWriter(const std::string& path, BagTopics topics = {});
  ~BagRgbdWriter();  ///< closes the bag (errors are swallowed here: call close() to see them)
  BagRgbdWriter(const BagRgbdWriter&) = delete;
  BagRgbdWriter& operator=(const BagRgbdWriter&) = delete;

  /// Appends one frame (bgr CV_8UC3, depth_m CV_32FC1 of the same size, valid camera). Throws
  /// std::runtime_error for other types/sizes or after close().
  void write(const RgbdFrame& frame);
  /// Flushes and closes the bag; further write() calls throw. Safe to call twice.
  void close();
  /// Frames written so far.
  std::size_t framesWritten() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reads RGB-D frames from a bag: each colour message is associated with the depth message of
/// the nearest header stamp within `max_dt_s`; colour messages without one are skipped.
/// Accepted encodings: colour rgb8, bgr8, mono8 (converted to BGR); depth 32FC1 [m] (NaN -> 0)
/// and 16UC1 [mm] (as OpenNI publishes). Anything else is a std::runtime_error naming the topic,
/// the encoding and the accepted ones.
class BagRgbdReader {
 public:
  /// Opens the bag and indexes the rgb and depth topics (reads every header once). Throws
  /// std::runtime_error when the bag cannot be read, when a topic is missing (listing the topics
  /// that are in the bag), has the wrong message type, or when no pair associates.
  explicit BagRgbdReader(const std::string& path, BagTopics topics = {}, double max_dt_s = 0.02);
  ~BagRgbdReader();
  BagRgbdReader(const BagRgbdReader&) = delete;
  BagRgbdReader& operator=(const BagRgbdReader&) = delete;

  /// Number of associated RGB-D pairs.
  std::size_t size() const;
  /// Pair `i` (0 <= i < size(), else std::out_of_range), ordered by colour stamp. `camera` is
  /// camera() (so a bag without camera_info needs setCamera() first). Thread-safe.
  RgbdFrame load(std::size_t i) const;
  /// Colour header stamp of pair `i` [ns].
  Timestamp stampNs(std::size_t i) const;
  /// Intrinsics: the setCamera() value, else the first message on topics.camera_info. Throws
  /// std::runtime_error when neither exists, telling to pass --camera NAME_OR_YAML.
  CameraIntrinsics camera() const;
  /// Overrides the intrinsics (e.g. from a camera YAML when the bag has no camera_info).
  void setCamera(const CameraIntrinsics& camera);
  /// "topic [type] (N msgs)" for every connection in the bag, for messages and tools.
  std::vector<std::string> describeTopics() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho::tools
