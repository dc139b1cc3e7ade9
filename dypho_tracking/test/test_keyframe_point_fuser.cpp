/// The fuse step (keyframe_point_fuser.h): duplicates of one scene point made by two keyframes are
/// merged, a feature without a point observes the point it matches, and a feature whose depth
/// disagrees with the point is left alone; points on probation or seen on a moving surface are
/// not fused.

#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tracking/keyframe_point_fuser.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

const Pinhole kPinhole{500.0, 500.0, 320.0, 240.0};

/// Scene points on a wall 3 m in front of the first camera, with one descriptor each.
struct Scene {
  std::vector<Eigen::Vector3d> p_world_m;
  cv::Mat descriptors;  ///< row i = descriptor of point i
  Scene() {
    std::mt19937 rng(5);
    for (int y = 0; y < 6; ++y) {
      for (int x = 0; x < 12; ++x) p_world_m.emplace_back(-1.1 + 0.2 * x, -0.5 + 0.2 * y, 3.0);
    }
    descriptors.create(static_cast<int>(p_world_m.size()), 32, CV_8UC1);
    cv::randu(descriptors, 0, 256);
  }
};

/// Keyframe `id` at `T_world_camera` with one feature per scene point in `indices` (measured
/// depth scaled by `depth_scale` for the points in `wrong_depth`); map_point_ids all -1.
MapKeyframe makeKeyframe(std::int64_t id, const Eigen::Isometry3d& T_world_camera, const Scene& scene,
                         const std::vector<int>& indices, const std::set<int>& wrong_depth = {},
                         double depth_scale = 1.0) {
  MapKeyframe kf;
  kf.id = id;
  kf.T_world_camera = T_world_camera;
  kf.features.descriptors.create(static_cast<int>(indices.size()), 32, CV_8UC1);
  for (std::size_t f = 0; f < indices.size(); ++f) {
    const int i = indices[f];
    Eigen::Vector3d p_camera = T_world_camera.inverse() * scene.p_world_m[static_cast<std::size_t>(i)];
    const Eigen::Vector2d uv = kPinhole.project(p_camera);
    if (wrong_depth.count(i) > 0) p_camera *= depth_scale;  // same pixel, another depth
    kf.features.keypoints.emplace_back(static_cast<float>(uv.x()), static_cast<float>(uv.y()), 31.f);
    kf.features.uv_undistorted_px.push_back(uv);
    kf.features.depth_m.push_back(static_cast<float>(p_camera.z()));
    kf.features.p_camera_m.push_back(p_camera);
    scene.descriptors.row(i).copyTo(kf.features.descriptors.row(static_cast<int>(f)));
  }
  kf.map_point_ids.assign(indices.size(), -1);
  return kf;
}

std::vector<int> range(int first, int last) {
  std::vector<int> v;
  for (int i = first; i < last; ++i) v.push_back(i);
  return v;
}

TEST(KeyframePointFuser, MergesDuplicatesAndAddsMissingObservations) {
  const Scene scene;
  TrackingOptions options;
  options.fuse_keyframes = 10;
  options.point_probation_frames = 0;  // every point trusted at once (the next test covers probation)
  TrackerMap map(options);
  // Keyframe 0 sees points 0-59; the points of its features 55-59 were removed since (they had
  // been seen on people), so those features have none.
  const std::vector<std::int64_t> first_ids =
      map.addKeyframe(makeKeyframe(0, Eigen::Isometry3d::Identity(), scene, range(0, 60)));
  const std::vector<std::int64_t> removed(first_ids.begin() + 55, first_ids.end());
  ASSERT_EQ(map.removePointsCreatedBy(0, removed, 0).size(), 5u);
  EXPECT_EQ(map.points().size(), 55u);
  for (int f = 55; f < 60; ++f) EXPECT_EQ(map.keyframe(0)->map_point_ids[static_cast<std::size_t>(f)], -1);

  // Keyframe 1, 10 cm to the right, sees points 0-71: tracking matched 0-19; it made its own
  // copies of 20-71 (20-54 duplicates, 55-59 the points keyframe 0 has none of, 60-71 new). Its
  // point 30 was measured 20 % too far (the depth of another surface).
  Eigen::Isometry3d T_world_second = Eigen::Isometry3d::Identity();
  T_world_second.translation() = Eigen::Vector3d(0.1, 0.0, 0.0);
  MapKeyframe second = makeKeyframe(1, T_world_second, scene, range(0, 72), {30}, 1.2);
  for (int f = 0; f < 20; ++f)
    second.map_point_ids[static_cast<std::size_t>(f)] = first_ids[static_cast<std::size_t>(f)];
  const std::vector<std::int64_t> second_ids = map.addKeyframe(second);
  ASSERT_EQ(map.points().size(), 55u + 52u);
  EXPECT_EQ(map.sharedPoints(0, 1), 20);

  const FuseStats stats = fuseKeyframePoints(&map, 1, kPinhole, options);
  EXPECT_EQ(stats.merged, 34);  // 20-54 but the one with the wrong depth
  EXPECT_EQ(stats.added, 5);    // keyframe 0's features 55-59 observe keyframe 1's points
  EXPECT_EQ(map.sharedPoints(0, 1), 20 + 34 + 5);
  EXPECT_EQ(map.points().size(), 55u + 52u - 34u);
  // Each merged scene point is one map point seen by both keyframes, at the older position.
  for (int i = 20; i < 55; ++i) {
    const std::int64_t id0 = map.keyframe(0)->map_point_ids[static_cast<std::size_t>(i)];
    const std::int64_t id1 = map.keyframe(1)->map_point_ids[static_cast<std::size_t>(i)];
    if (i == 30) {
      EXPECT_NE(id0, id1) << "the point with the wrong depth must stay apart";
      continue;
    }
    EXPECT_EQ(id0, id1) << "scene point " << i;
    ASSERT_NE(map.point(id0), nullptr);
    EXPECT_EQ(map.point(id0)->observations.size(), 2u);
    EXPECT_LT((map.point(id0)->p_world_m - scene.p_world_m[static_cast<std::size_t>(i)]).norm(), 1e-9);
  }
  for (int i = 55; i < 60; ++i) {
    EXPECT_EQ(map.keyframe(0)->map_point_ids[static_cast<std::size_t>(i)], second_ids[static_cast<std::size_t>(i)]);
  }
  // A second pass finds nothing more to do.
  const FuseStats again = fuseKeyframePoints(&map, 1, kPinhole, options);
  EXPECT_EQ(again.merged, 0);
  EXPECT_EQ(again.added, 0);
}

TEST(KeyframePointFuser, PointsOnProbationOrSeenOnAMovingSurfaceAreNotFused) {
  const Scene scene;
  TrackingOptions options;
  options.fuse_keyframes = 10;
  options.point_probation_frames = 3;
  TrackerMap map(options);
  // Keyframe 0 sees points 0-59. Points 0-39 agreed with the pose on three frames (verified),
  // 40-59 are still on probation; 25-29 were seen once on a person (kept: min_hits 100).
  const std::vector<std::int64_t> first_ids =
      map.addKeyframe(makeKeyframe(0, Eigen::Isometry3d::Identity(), scene, range(0, 60)));
  const std::vector<std::int64_t> verified(first_ids.begin(), first_ids.begin() + 40);
  for (int frame = 0; frame < 3; ++frame) ASSERT_TRUE(map.updateProbation(verified, {}).empty());
  const std::vector<std::int64_t> on_person(first_ids.begin() + 25, first_ids.begin() + 30);
  ASSERT_TRUE(map.cullMovingPoints(on_person, 100).empty());
  ASSERT_TRUE(map.isVerified(first_ids[0]));
  ASSERT_FALSE(map.isVerified(first_ids[40]));

  // Keyframe 1, 10 cm to the right, sees 0-59: tracking matched 0-19, it made its own copies of
  // 20-59 (on probation); its copy of 35 was seen on a person.
  Eigen::Isometry3d T_world_second = Eigen::Isometry3d::Identity();
  T_world_second.translation() = Eigen::Vector3d(0.1, 0.0, 0.0);
  MapKeyframe second = makeKeyframe(1, T_world_second, scene, range(0, 60));
  for (int f = 0; f < 20; ++f)
    second.map_point_ids[static_cast<std::size_t>(f)] = first_ids[static_cast<std::size_t>(f)];
  const std::vector<std::int64_t> second_ids = map.addKeyframe(second);
  ASSERT_TRUE(map.cullMovingPoints({second_ids[35]}, 100).empty());

  const FuseStats stats = fuseKeyframePoints(&map, 1, kPinhole, options);
  EXPECT_EQ(stats.merged, 14);  // 20-39 but 25-29 and 35
  EXPECT_EQ(stats.added, 0);
  for (int i = 20; i < 60; ++i) {
    const std::int64_t id0 = map.keyframe(0)->map_point_ids[static_cast<std::size_t>(i)];
    const std::int64_t id1 = map.keyframe(1)->map_point_ids[static_cast<std::size_t>(i)];
    const bool fused = i < 40 && (i < 25 || i >= 30) && i != 35;
    EXPECT_EQ(id0 == id1, fused) << "scene point " << i;
    // The trusted point stays: keyframe 0's, still verified.
    if (fused) {
      EXPECT_EQ(id0, first_ids[static_cast<std::size_t>(i)]);
      EXPECT_TRUE(map.isVerified(id0));
    }
  }
}

TEST(KeyframePointFuser, OffChangesNothingAndAddObservationRefusesATakenFeature) {
  const Scene scene;
  TrackingOptions options;
  options.fuse_keyframes = 0;
  TrackerMap map(options);
  const auto first_ids = map.addKeyframe(makeKeyframe(0, Eigen::Isometry3d::Identity(), scene, range(0, 40)));
  MapKeyframe second = makeKeyframe(1, Eigen::Isometry3d::Identity(), scene, range(0, 40));
  for (int f = 0; f < 20; ++f)
    second.map_point_ids[static_cast<std::size_t>(f)] = first_ids[static_cast<std::size_t>(f)];
  const auto second_ids = map.addKeyframe(second);
  const FuseStats stats = fuseKeyframePoints(&map, 1, kPinhole, options);
  EXPECT_EQ(stats.merged + stats.added, 0);
  EXPECT_EQ(map.points().size(), 60u);
  // Feature 25 of keyframe 0 holds a point already; keyframe 1 observes its own point 25.
  EXPECT_FALSE(map.addObservation(second_ids[25], 0, 25));
  EXPECT_FALSE(map.addObservation(first_ids[3], 1, 30));  // keyframe 1 observes point 3 already
  EXPECT_FALSE(map.addObservation(first_ids[3], 7, 0));   // unknown keyframe
  EXPECT_FALSE(map.addObservation(first_ids[3], 0, 99));  // no such feature
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
