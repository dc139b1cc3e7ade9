#pragma once
/// \file keyframe_points.h
/// The 3D points of the reference keyframe that frames are tracked against.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/tracking/frame_features.h"

namespace dypho {
namespace tracking {

/// Reference keyframe as tracking needs it: per point its world position, keypoint (level,
/// angle) and descriptor. All vectors have the same length; index i is one point.
struct KeyframePoints {
  /// the published keyframe (frame, mask, pose) when built by makeKeyframePoints; views of the
  /// tracker's map (TrackerMap::localPoints) leave it null, the map keeps no images
  KeyframeConstPtr keyframe;
  std::vector<Eigen::Vector3d> p_world_m;   ///< 3D point in the world [m]
  std::vector<cv::KeyPoint> keypoints;      ///< keypoint in the keyframe image (level-0 px)
  cv::Mat descriptors;                      ///< row i = ORB descriptor of point i, CV_8UC1
  std::vector<std::int64_t> map_point_ids;  ///< unique id of point i
  /// Distance camera -> point when the keypoint was detected [m]; empty = unknown. When filled,
  /// projection matching predicts the pyramid level from the current distance (scale invariance).
  std::vector<double> reference_distance_m;
  /// Per point: 1 = it carries the pose, 0 = on probation (TrackingOptions::point_probation_frames);
  /// empty = every point carries the pose.
  std::vector<std::uint8_t> verified;

  /// Number of points.
  std::size_t size() const { return p_world_m.size(); }
};

/// Builds a keyframe from the features of a tracked frame.
///
/// Every feature becomes a keyframe point at T_world_camera * p_camera. Map point ids: a feature
/// listed in `previous_match` (feature index -> index into `previous`, -1 = none) inherits the id of
/// the previous keyframe's point it was matched to as a pose inlier; every other feature gets a new
/// id from `next_map_point_id` (incremented). The 3D position always comes from this frame's depth.
/// The returned Keyframe holds deep copies of `frame` and `mask` (so callers may reuse buffers).
KeyframePoints makeKeyframePoints(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask,
                                  const Eigen::Isometry3d& T_world_camera, const FrameFeatures& features,
                                  const KeyframePoints* previous, const std::vector<int>& previous_match,
                                  std::int64_t* next_map_point_id);

/// The published keyframe (deep copies of `frame` and `mask`) with one KeyframeKeypoint per
/// feature carrying `map_point_ids[i]` (same length as the features; -1 = none).
KeyframeConstPtr makeKeyframe(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask,
                              const Eigen::Isometry3d& T_world_camera, const FrameFeatures& features,
                              const std::vector<std::int64_t>& map_point_ids);

}  // namespace tracking
}  // namespace dypho
