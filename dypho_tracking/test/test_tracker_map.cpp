/// TrackerMap: point creation and observations, covisibility, local view, culling, fusion, pose
/// correction.

#include <set>

#include <gtest/gtest.h>

#include "dypho/tracking/tracker_map.h"

namespace dypho {
namespace tracking {
namespace {

/// Keyframe with n features at (i, 0, 2) m in its camera frame; ids given (or -1 = new).
MapKeyframe makeKf(std::int64_t id, const std::vector<std::int64_t>& ids, double x_m = 0) {
  MapKeyframe kf;
  kf.id = id;
  kf.T_world_camera.translation() = Eigen::Vector3d(x_m, 0, 0);
  for (size_t i = 0; i < ids.size(); ++i) {
    cv::KeyPoint kp(10.f * i, 5.f, 31.f);
    kf.features.keypoints.push_back(kp);
    kf.features.uv_undistorted_px.emplace_back(10.0 * i, 5.0);
    kf.features.depth_m.push_back(2.f);
    kf.features.p_camera_m.emplace_back(0.1 * i, 0, 2);
  }
  kf.features.descriptors = cv::Mat(static_cast<int>(ids.size()), 32, CV_8UC1, cv::Scalar(7));
  kf.map_point_ids = ids;
  return kf;
}

TEST(TrackerMap, NewPointsAndObservations) {
  TrackerMap map{TrackingOptions()};
  const auto ids0 = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(20, -1)));
  ASSERT_EQ(ids0.size(), 20u);
  EXPECT_EQ(map.points().size(), 20u);
  // Keyframe 1 re-observes the first 16 points and adds 4 new ones.
  std::vector<std::int64_t> ids1(ids0.begin(), ids0.begin() + 16);
  ids1.resize(20, -1);
  const auto out1 = map.addKeyframe(makeKf(1, ids1, 0.5));
  EXPECT_EQ(map.points().size(), 24u);
  EXPECT_EQ(map.point(ids0[3])->observations.size(), 2u);
  EXPECT_EQ(map.sharedPoints(0, 1), 16);
  // Positions stay those of the first observation.
  EXPECT_NEAR(map.point(ids0[3])->p_world_m.x(), 0.3, 1e-12);
  EXPECT_NEAR(map.point(out1[19])->p_world_m.x(), 0.5 + 1.9, 1e-12);
}

TEST(TrackerMap, CovisibilityOrderAndLocalView) {
  TrackingOptions o;
  o.covisibility_min_shared = 5;
  o.local_map_keyframes = 1;
  TrackerMap map(o);
  const auto a = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(20, -1)));
  std::vector<std::int64_t> b_ids(a.begin(), a.begin() + 6);  // 6 shared with 0
  b_ids.resize(20, -1);
  const auto b = map.addKeyframe(makeKf(1, b_ids));
  std::vector<std::int64_t> c_ids(b.begin(), b.begin() + 15);  // 15 shared with 1, 6 with 0
  c_ids.resize(20, -1);
  map.addKeyframe(makeKf(2, c_ids));
  const auto cov = map.covisibleKeyframes(2, 10);
  ASSERT_EQ(cov.size(), 2u);
  EXPECT_EQ(cov[0], 1);  // most shared first
  EXPECT_EQ(cov[1], 0);
  // Below the minimum: 4 shared points do not count.
  o.covisibility_min_shared = 7;
  TrackerMap strict(o);
  strict.addKeyframe(makeKf(0, std::vector<std::int64_t>(20, -1)));
  EXPECT_TRUE(strict.covisibleKeyframes(0, 10).empty());
  // Local view of 2 with local_map_keyframes = 1: points of keyframes 2 and 1, no duplicates.
  const KeyframePoints view = map.localPoints(2);
  std::set<std::int64_t> unique(view.map_point_ids.begin(), view.map_point_ids.end());
  EXPECT_EQ(unique.size(), view.size());
  EXPECT_EQ(view.size(), 20u + 5u);  // keyframe 2's 20 + keyframe 1's 5 not seen by 2
  EXPECT_EQ(view.reference_distance_m.size(), view.size());
  EXPECT_EQ(map.keyframePoints(2).size(), 20u);
}

TEST(TrackerMap, CullsPointsRarelyFound) {
  TrackingOptions o;
  o.cull_min_found_ratio = 0.25;
  TrackerMap map(o);
  const auto ids = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(4, -1)));
  for (int f = 0; f < 12; ++f) {
    std::vector<std::int64_t> found{ids[0]};
    if (f < 2) found.push_back(ids[1]);  // 2 of 12 < 25 %
    if (f < 3) found.push_back(ids[2]);  // 3 of 12 = 25 %: kept
    map.updateVisibility(ids, found);
  }
  EXPECT_EQ(map.cullPoints(), 2);  // ids[1] and ids[3] (never found)
  EXPECT_NE(map.point(ids[0]), nullptr);
  EXPECT_EQ(map.point(ids[1]), nullptr);
  EXPECT_NE(map.point(ids[2]), nullptr);
  EXPECT_EQ(map.keyframe(0)->map_point_ids[1], -1);
}

TEST(TrackerMap, MergeAndPoseCorrection) {
  TrackerMap map{TrackingOptions()};
  const auto a = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(3, -1)));
  const auto b = map.addKeyframe(makeKf(5, std::vector<std::int64_t>(3, -1), 1.0));
  ASSERT_TRUE(map.mergePoints(a[0], b[0]));
  EXPECT_EQ(map.point(b[0]), nullptr);
  EXPECT_EQ(map.keyframe(5)->map_point_ids[0], a[0]);
  EXPECT_EQ(map.point(a[0])->observations.size(), 2u);
  EXPECT_FALSE(map.mergePoints(a[0], a[0]));
  // Moving keyframe 5 by +1 m in y moves the points it created, not those of keyframe 0.
  Eigen::Isometry3d T = map.keyframe(5)->T_world_camera;
  T.translation().y() += 1.0;
  map.applyKeyframePoses({{5, T}});
  EXPECT_NEAR(map.point(b[1])->p_world_m.y(), 1.0, 1e-12);
  EXPECT_NEAR(map.point(a[0])->p_world_m.y(), 0.0, 1e-12);
}

}  // namespace
}  // namespace tracking
}  // namespace dypho
