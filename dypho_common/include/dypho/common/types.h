#pragma once
/// \file types.h
/// Value types exchanged between the mask, tracking and mapping cores. Types only, no algorithms.
///
/// Conventions (also in README "Frames and conventions"):
///  - time: `Timestamp` = int64 nanoseconds since the Unix epoch (or since the start of a synthetic run);
///  - poses: `T_a_b` maps points from frame b into frame a (`p_a = T_a_b * p_b`); the camera frame
///    is the optical frame (x right, y down, z forward);
///  - colour images: CV_8UC3 in BGR order;
///  - depth images: CV_32FC1 in metres, registered to the colour image; 0 or NaN = no measurement;
///  - dynamic masks: CV_8UC1, 255 = dynamic (excluded), 0 = static. (The paper writes the inverse,
///    1 = static; we keep 255 = dynamic everywhere at our API edges and on topics, `mono8`.)

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/camera.h"

namespace dypho {

/// Time in nanoseconds.
using Timestamp = std::int64_t;

/// Converts seconds (as in TUM text files and ROS stamps) to nanoseconds, rounding to nearest.
inline Timestamp secondsToTimestamp(double t_s) { return static_cast<Timestamp>(t_s * 1e9 + (t_s >= 0 ? 0.5 : -0.5)); }

/// Converts nanoseconds to seconds.
inline double timestampToSeconds(Timestamp t_ns) { return static_cast<double>(t_ns) * 1e-9; }

/// Value of a dynamic pixel in a `DynamicMask`.
constexpr std::uint8_t kMaskDynamic = 255;
/// Value of a static pixel in a `DynamicMask`.
constexpr std::uint8_t kMaskStatic = 0;

/// One synchronised RGB-D measurement.
struct RgbdFrame {
  Timestamp stamp_ns = 0;   ///< acquisition time of the colour image [ns]
  cv::Mat bgr;              ///< colour, CV_8UC3 BGR, camera.width x camera.height
  cv::Mat depth_m;          ///< depth, CV_32FC1 [m], registered to `bgr`; 0/NaN = invalid
  CameraIntrinsics camera;  ///< intrinsics of `bgr` (distortion may be non-zero)
};

/// Points that tracking saw move on one frame (tracking -> mask): the matches the static check
/// found carried along with people it did not mask. The mask grows them over the surface they lie
/// on from the next frame on.
struct MovingPoints {
  Timestamp stamp_ns = 0;               ///< the frame they were seen in [ns]
  std::vector<cv::Point3f> p_camera_m;  ///< at their measured depth, that frame's camera optical frame [m]
};

/// A keypoint of a keyframe as handed from tracking to mapping.
struct KeyframeKeypoint {
  float u_px = 0.f;                ///< pixel column in the (distorted) input image [px]
  float v_px = 0.f;                ///< pixel row in the (distorted) input image [px]
  float depth_m = 0.f;             ///< measured depth at the keypoint [m]; 0 = none
  std::int64_t map_point_id = -1;  ///< id of the associated map point, -1 when none
};

/// A keyframe: the frame, its dynamic mask, its pose and its keypoints.
struct Keyframe {
  std::int64_t id = -1;  ///< keyframe id, unique and increasing within a run
  RgbdFrame frame;       ///< the RGB-D data
  cv::Mat mask;          ///< CV_8UC1, 255 = dynamic; empty = everything static
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();  ///< camera optical frame in world
  std::vector<KeyframeKeypoint> keypoints;                           ///< static keypoints used by tracking
};

using KeyframeConstPtr = std::shared_ptr<const Keyframe>;

/// Keyframe poses changed after the keyframe was handed on (local BA, loop closure), as one
/// batch: (keyframe id, new T_world_camera). Tracking emits them; mapping re-anchors.
using KeyframePoseCorrections = std::vector<std::pair<std::int64_t, Eigen::Isometry3d>>;

}  // namespace dypho
