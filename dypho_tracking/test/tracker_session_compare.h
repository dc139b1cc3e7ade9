#pragma once
/// \file tracker_session_compare.h
/// Test helpers: two tracker sessions compared field by field, to the bit (the file format is
/// lossless).

#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "dypho/tracking/tracker_session.h"

namespace dypho {
namespace tracking {
namespace test {

inline bool sameBytes(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() || b.empty()) return a.empty() && b.empty();
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

inline void expectSameKeypoint(const cv::KeyPoint& a, const cv::KeyPoint& b, const std::string& where) {
  EXPECT_EQ(a.pt.x, b.pt.x) << where;
  EXPECT_EQ(a.pt.y, b.pt.y) << where;
  EXPECT_EQ(a.size, b.size) << where;
  EXPECT_EQ(a.angle, b.angle) << where;
  EXPECT_EQ(a.response, b.response) << where;
  EXPECT_EQ(a.octave, b.octave) << where;
  EXPECT_EQ(a.class_id, b.class_id) << where;
}

inline void expectSameKeyframe(const MapKeyframe& a, const MapKeyframe& b) {
  const std::string where = "keyframe " + std::to_string(a.id);
  EXPECT_EQ(a.id, b.id) << where;
  EXPECT_EQ(a.stamp_ns, b.stamp_ns) << where;
  EXPECT_TRUE(a.T_world_camera.matrix() == b.T_world_camera.matrix()) << where;
  EXPECT_TRUE(a.blur_rates.omega_rad_s == b.blur_rates.omega_rad_s) << where;
  EXPECT_TRUE(a.blur_rates.velocity_m_s == b.blur_rates.velocity_m_s) << where;
  EXPECT_EQ(a.blur_exposure_s, b.blur_exposure_s) << where;
  EXPECT_EQ(a.map_point_ids, b.map_point_ids) << where;
  const FrameFeatures& fa = a.features;
  const FrameFeatures& fb = b.features;
  ASSERT_EQ(fa.size(), fb.size()) << where;
  EXPECT_EQ(fa.depth_m, fb.depth_m) << where;
  EXPECT_TRUE(sameBytes(fa.descriptors, fb.descriptors)) << where;
  for (std::size_t i = 0; i < fa.size(); ++i) {
    expectSameKeypoint(fa.keypoints[i], fb.keypoints[i], where + " feature " + std::to_string(i));
    EXPECT_TRUE(fa.uv_undistorted_px[i] == fb.uv_undistorted_px[i]) << where << " feature " << i;
    EXPECT_TRUE(fa.p_camera_m[i] == fb.p_camera_m[i]) << where << " feature " << i;
  }
}

inline void expectSamePoint(const MapPoint& a, const MapPoint& b) {
  const std::string where = "map point " + std::to_string(a.id);
  EXPECT_EQ(a.id, b.id) << where;
  EXPECT_TRUE(a.p_world_m == b.p_world_m) << where;
  EXPECT_TRUE(sameBytes(a.descriptor, b.descriptor)) << where;
  expectSameKeypoint(a.keypoint, b.keypoint, where);
  EXPECT_EQ(a.reference_distance_m, b.reference_distance_m) << where;
  EXPECT_EQ(a.first_keyframe_id, b.first_keyframe_id) << where;
  EXPECT_EQ(a.observations, b.observations) << where;
  EXPECT_EQ(a.num_visible, b.num_visible) << where;
  EXPECT_EQ(a.num_found, b.num_found) << where;
  EXPECT_EQ(a.num_on_dynamic, b.num_on_dynamic) << where;
  EXPECT_EQ(a.num_on_dynamic_still, b.num_on_dynamic_still) << where;
  EXPECT_EQ(a.num_confirmed, b.num_confirmed) << where;
  EXPECT_EQ(a.num_refuted, b.num_refuted) << where;
}

inline void expectSameMap(const TrackerMapState& a, const TrackerMapState& b) {
  EXPECT_EQ(a.next_point_id, b.next_point_id);
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  for (auto ka = a.keyframes.begin(), kb = b.keyframes.begin(); ka != a.keyframes.end(); ++ka, ++kb) {
    expectSameKeyframe(ka->second, kb->second);
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (auto pa = a.points.begin(), pb = b.points.begin(); pa != a.points.end(); ++pa, ++pb) {
    expectSamePoint(pa->second, pb->second);
  }
  ASSERT_EQ(a.removed.size(), b.removed.size());
  for (auto ra = a.removed.begin(), rb = b.removed.begin(); ra != a.removed.end(); ++ra, ++rb) {
    EXPECT_EQ(ra->first, rb->first);
    EXPECT_EQ(ra->second.parent_id, rb->second.parent_id) << "removed keyframe " << ra->first;
    EXPECT_TRUE(ra->second.T_parent_keyframe.matrix() == rb->second.T_parent_keyframe.matrix())
        << "removed keyframe " << ra->first;
  }
}

inline void expectSameSession(const TrackerSession& a, const TrackerSession& b) {
  EXPECT_TRUE(sameCamera(a.camera, b.camera));
  EXPECT_EQ(a.next_keyframe_id, b.next_keyframe_id);
  EXPECT_EQ(a.last_loop_keyframe_id, b.last_loop_keyframe_id);
  EXPECT_EQ(a.unanchored_from_keyframe_id, b.unanchored_from_keyframe_id);
  EXPECT_EQ(a.last_stamp_ns, b.last_stamp_ns);
  EXPECT_TRUE(a.T_world_last.matrix() == b.T_world_last.matrix());
  EXPECT_TRUE(a.T_world_odom.matrix() == b.T_world_odom.matrix());
  ASSERT_EQ(a.reported_poses.size(), b.reported_poses.size());
  for (auto ra = a.reported_poses.begin(), rb = b.reported_poses.begin(); ra != a.reported_poses.end(); ++ra, ++rb) {
    EXPECT_EQ(ra->first, rb->first);
    EXPECT_TRUE(ra->second.matrix() == rb->second.matrix()) << "reported pose of keyframe " << ra->first;
  }
  expectSameMap(a.map, b.map);
}

}  // namespace test
}  // namespace tracking
}  // namespace dypho
