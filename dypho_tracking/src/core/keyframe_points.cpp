#include "dypho/tracking/keyframe_points.h"

#include <memory>

namespace dypho {
namespace tracking {

KeyframePoints makeKeyframePoints(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask,
                                  const Eigen::Isometry3d& T_world_camera, const FrameFeatures& features,
                                  const KeyframePoints* previous, const std::vector<int>& previous_match,
                                  std::int64_t* next_map_point_id) {
  auto keyframe = std::make_shared<Keyframe>();
  keyframe->id = keyframe_id;
  keyframe->frame.stamp_ns = frame.stamp_ns;
  keyframe->frame.camera = frame.camera;
  keyframe->frame.bgr = frame.bgr.clone();
  keyframe->frame.depth_m = frame.depth_m.clone();
  keyframe->mask = mask.clone();
  keyframe->T_world_camera = T_world_camera;

  KeyframePoints out;
  const size_t n = features.size();
  out.p_world_m.reserve(n);
  out.map_point_ids.reserve(n);
  out.keypoints = features.keypoints;
  out.descriptors = features.descriptors.clone();
  keyframe->keypoints.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    std::int64_t id = -1;
    Eigen::Vector3d p_world = T_world_camera * features.p_camera_m[i];
    if (previous != nullptr && i < previous_match.size() && previous_match[i] >= 0 &&
        static_cast<size_t>(previous_match[i]) < previous->size()) {
      id = previous->map_point_ids[static_cast<size_t>(previous_match[i])];
    } else {
      id = (*next_map_point_id)++;
    }
    out.p_world_m.push_back(p_world);
    out.map_point_ids.push_back(id);
    KeyframeKeypoint kp;
    kp.u_px = features.keypoints[i].pt.x;
    kp.v_px = features.keypoints[i].pt.y;
    kp.depth_m = features.depth_m[i];
    kp.map_point_id = id;
    keyframe->keypoints.push_back(kp);
  }
  out.keyframe = std::move(keyframe);
  return out;
}

KeyframeConstPtr makeKeyframe(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask,
                              const Eigen::Isometry3d& T_world_camera, const FrameFeatures& features,
                              const std::vector<std::int64_t>& map_point_ids) {
  auto keyframe = std::make_shared<Keyframe>();
  keyframe->id = keyframe_id;
  keyframe->frame.stamp_ns = frame.stamp_ns;
  keyframe->frame.camera = frame.camera;
  keyframe->frame.bgr = frame.bgr.clone();
  keyframe->frame.depth_m = frame.depth_m.clone();
  keyframe->mask = mask.clone();
  keyframe->T_world_camera = T_world_camera;
  keyframe->keypoints.reserve(features.size());
  for (size_t i = 0; i < features.size(); ++i) {
    KeyframeKeypoint kp;
    kp.u_px = features.keypoints[i].pt.x;
    kp.v_px = features.keypoints[i].pt.y;
    kp.depth_m = features.depth_m[i];
    kp.map_point_id = i < map_point_ids.size() ? map_point_ids[i] : -1;
    keyframe->keypoints.push_back(kp);
  }
  return keyframe;
}

}  // namespace tracking
}  // namespace dypho
