/// TrackerMap: point creation and observations, covisibility, local view, culling, fusion, pose
/// correction, redundant keyframes and their removal.

#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "dypho/tracking/tracker_map.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

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

/// makeKf(id, 20 new points, x_m), turned by `yaw_deg` about the camera's y axis.
MapKeyframe turnedKf(std::int64_t id, double x_m, double yaw_deg) {
  MapKeyframe kf = makeKf(id, std::vector<std::int64_t>(20, -1), x_m);
  kf.T_world_camera.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return kf;
}

/// Five keyframes of 20 points each, none shared; keyframe 4 is the reference.
TrackerMap fiveViews(const TrackingOptions& o) {
  TrackerMap map(o);
  map.addKeyframe(turnedKf(0, 0.0, 0.0));   // the same view as 4 (5 deg off)
  map.addKeyframe(turnedKf(1, 0.1, 10.0));  // 5 deg and 10 cm off 4
  map.addKeyframe(turnedKf(2, 0.0, 40.0));  // turned too far
  map.addKeyframe(turnedKf(3, 0.5, 0.0));   // moved too far
  map.addKeyframe(turnedKf(4, 0.0, 5.0));
  return map;
}

// Keyframes that share no point with the reference but look at its part of the scene (a sweep
// blurred the other way) join the tracking view; those turned or moved too far do not.
TEST(TrackerMap, TrackingViewTakesKeyframesOfTheSameViewWithoutSharedPoints) {
  TrackingOptions o;
  o.local_map_nearby_keyframes = 10;
  o.local_map_nearby_max_angle_deg = 20.0;
  o.local_map_nearby_max_distance_m = 0.3;
  const TrackerMap map = fiveViews(o);
  EXPECT_EQ(map.localPoints(4).size(), 20u);                                    // no covisible keyframe
  EXPECT_EQ(map.nearbyKeyframes(4, {}, 0), (std::vector<std::int64_t>{0, 1}));  // closest view first
  const KeyframePoints view = map.trackingPoints(4, 0);
  EXPECT_EQ(view.size(), 60u);
  EXPECT_EQ(std::set<std::int64_t>(view.map_point_ids.begin(), view.map_point_ids.end()).size(), 60u);
  // An unanchored segment starting at keyframe 1 keeps keyframe 0 out; so does an exclusion.
  EXPECT_EQ(map.trackingPoints(4, 1).size(), 40u);
  EXPECT_EQ(map.nearbyKeyframes(4, {1}, 0), (std::vector<std::int64_t>{0}));
  o.local_map_nearby_keyframes = 1;  // the closest one only
  EXPECT_EQ(fiveViews(o).nearbyKeyframes(4, {}, 0), (std::vector<std::int64_t>{0}));
  o.local_map_nearby_keyframes = 0;  // off: covisible keyframes only
  EXPECT_EQ(fiveViews(o).trackingPoints(4, 0).size(), 20u);
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

TEST(TrackerMap, CullsMovingPointsButNotStaticOnesTheMaskCovered) {
  TrackerMap map{TrackingOptions()};
  const auto ids = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(3, -1)));
  // ids[0]: a pose inlier in 5 frames (static), then covered by the mask twice: kept.
  // ids[1]: never found, seen on a dynamic surface twice: removed on the second sighting.
  // ids[2]: seen on a dynamic surface once: kept.
  for (int f = 0; f < 5; ++f) map.updateVisibility(ids, {ids[0]});
  EXPECT_TRUE(map.cullMovingPoints({ids[0], ids[1], ids[2]}, 2).empty());
  const std::vector<std::int64_t> removed = map.cullMovingPoints({ids[0], ids[1]}, 2);
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed[0], ids[1]);
  EXPECT_EQ(map.point(ids[1]), nullptr);
  EXPECT_EQ(map.keyframe(0)->map_point_ids[1], -1);
  EXPECT_NE(map.point(ids[0]), nullptr);
  EXPECT_NE(map.point(ids[2]), nullptr);
  // min_hits 0 disables the test.
  EXPECT_TRUE(map.cullMovingPoints({ids[2], ids[2], ids[2]}, 0).empty());
}

// moving_point_still_only: sightings while the camera moved are counted (num_on_dynamic) but only
// those while it was still remove a point.
TEST(TrackerMap, CullsMovingPointsOnSightingsWhileStillOnlyWhenAsked) {
  TrackerMap map{TrackingOptions()};
  const auto ids = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(2, -1)));
  // Both never found; three sightings each while the camera moved.
  for (int f = 0; f < 3; ++f) {
    EXPECT_TRUE(map.cullMovingPoints({ids[0], ids[1]}, 2, /*camera_still=*/false, /*still_only=*/true).empty());
  }
  EXPECT_EQ(map.point(ids[0])->num_on_dynamic, 3);
  EXPECT_EQ(map.point(ids[0])->num_on_dynamic_still, 0);
  // One sighting while still: one of two.
  EXPECT_TRUE(map.cullMovingPoints({ids[0]}, 2, true, true).empty());
  // The second while still removes ids[0]; ids[1], seen while moving only, stays.
  const std::vector<std::int64_t> removed = map.cullMovingPoints({ids[0], ids[1]}, 2, true, true);
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed[0], ids[0]);
  EXPECT_NE(map.point(ids[1]), nullptr);
  EXPECT_EQ(map.point(ids[1])->num_on_dynamic_still, 1);
  // Without still_only every sighting counts: ids[1] has 5.
  EXPECT_EQ(map.cullMovingPoints({ids[1]}, 2, false, false).size(), 1u);
}

// Safe start: the first keyframe's points are removed after enough sightings on a dynamic
// surface even when they were pose inliers every frame; other keyframes' points are not.
TEST(TrackerMap, RemovesUnverifiedPointsOfTheFirstKeyframeOnly) {
  TrackerMap map{TrackingOptions()};
  const auto first = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(2, -1)));
  const auto second = map.addKeyframe(makeKf(1, {first[0], -1}, 0.1));
  const std::int64_t later_point = second[1];
  ASSERT_NE(later_point, first[0]);
  for (int f = 0; f < 5; ++f)
    map.updateVisibility({first[0], first[1], later_point}, {first[0], first[1], later_point});
  const std::vector<std::int64_t> seen{first[1], later_point};
  for (int hit = 1; hit <= 2; ++hit) {
    map.cullMovingPoints(seen, 0);  // counts the sighting, removes nothing (test off)
    EXPECT_TRUE(map.removePointsCreatedBy(0, seen, 3).empty()) << "after " << hit << " sightings";
  }
  map.cullMovingPoints(seen, 0);
  const std::vector<std::int64_t> removed = map.removePointsCreatedBy(0, seen, 3);
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed[0], first[1]);
  EXPECT_EQ(map.point(first[1]), nullptr);
  EXPECT_NE(map.point(later_point), nullptr);  // created by keyframe 1
  EXPECT_NE(map.point(first[0]), nullptr);     // never seen on a dynamic surface
}

TEST(TrackerMap, ProbationVerifiesAgreeingPointsAndRemovesRefutedOnes) {
  TrackingOptions o;
  o.point_probation_frames = 3;
  o.point_probation_max_refuted = 2;
  TrackerMap map(o);
  const auto ids = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(4, -1)));
  // New points are on probation, and the local view says so.
  KeyframePoints view = map.localPoints(0);
  ASSERT_EQ(view.verified.size(), 4u);
  for (std::uint8_t v : view.verified) EXPECT_EQ(v, 0);
  EXPECT_FALSE(map.isVerified(ids[0]));
  // ids[0] agrees on three frames: verified. ids[1] agrees twice: not yet.
  for (int frame = 0; frame < 3; ++frame) {
    std::vector<std::int64_t> confirmed{ids[0]};
    if (frame < 2) confirmed.push_back(ids[1]);
    EXPECT_TRUE(map.updateProbation(confirmed, {}).empty());
  }
  EXPECT_TRUE(map.isVerified(ids[0]));
  EXPECT_FALSE(map.isVerified(ids[1]));
  view = map.localPoints(0);
  for (size_t i = 0; i < view.size(); ++i) {
    EXPECT_EQ(view.verified[i], view.map_point_ids[i] == ids[0] ? 1 : 0) << "point " << view.map_point_ids[i];
  }
  // One disagreement removes nothing; the second removes the unverified points, never a verified one.
  EXPECT_TRUE(map.updateProbation({}, {ids[0], ids[1], ids[2]}).empty());
  const auto removed = map.updateProbation({}, {ids[0], ids[1], ids[2]});
  EXPECT_EQ(std::set<std::int64_t>(removed.begin(), removed.end()), (std::set<std::int64_t>{ids[1], ids[2]}));
  EXPECT_NE(map.point(ids[0]), nullptr);
  EXPECT_EQ(map.point(ids[1]), nullptr);
  EXPECT_NE(map.point(ids[3]), nullptr);
  EXPECT_EQ(map.keyframe(0)->map_point_ids[1], -1);  // the keyframe no longer observes it
}

TEST(TrackerMap, ProbationOffEveryPointCarriesThePose) {
  TrackingOptions o;
  o.point_probation_frames = 0;
  TrackerMap map(o);
  const auto ids = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(3, -1)));
  EXPECT_TRUE(map.localPoints(0).verified.empty());
  EXPECT_TRUE(map.isVerified(ids[0]));
  EXPECT_TRUE(map.updateProbation({}, {ids[0], ids[0], ids[0]}).empty());
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

// ORB-SLAM's rule: a keyframe is redundant when >= ratio of its points are seen by >= 3 other
// keyframes at the same or a finer scale.
TEST(TrackerMap, RedundantKeyframeRule) {
  TrackerMap map{TrackingOptions()};
  const auto base = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(10, -1)));
  // Keyframe 1 sees the 10 points of keyframe 0 plus 1 of its own: 10 of 11 points.
  std::vector<std::int64_t> ids1 = base;
  ids1.push_back(-1);
  map.addKeyframe(makeKf(1, ids1, 0.1));
  map.addKeyframe(makeKf(2, base, 0.2));
  EXPECT_FALSE(map.isRedundant(1, 0.9));  // its points are seen by 2 others (0 and 2)
  map.addKeyframe(makeKf(3, base, 0.3));
  EXPECT_TRUE(map.isRedundant(1, 0.9));  // 10 of 11 = 0.91 seen by 3 others
  EXPECT_FALSE(map.isRedundant(1, 0.95));
  // Observers at a coarser scale (octave > own + 1) do not count.
  MapKeyframe coarse = makeKf(4, base, 0.4);
  for (cv::KeyPoint& kp : coarse.features.keypoints) kp.octave = 3;
  TrackerMap scaled{TrackingOptions()};
  scaled.addKeyframe(makeKf(0, base));
  scaled.addKeyframe(makeKf(1, ids1, 0.1));
  scaled.addKeyframe(makeKf(2, base, 0.2));
  scaled.addKeyframe(std::move(coarse));
  EXPECT_FALSE(scaled.isRedundant(1, 0.9));
  EXPECT_FALSE(map.isRedundant(42, 0.9));  // unknown
}

// A removed keyframe's observations go, points only it saw go, points it created get a new
// first keyframe, and its pose follows the keyframe it was attached to through later corrections
// (also when that one is removed in turn).
TEST(TrackerMap, RemovedKeyframeKeepsAPoseThatFollowsCorrections) {
  TrackingOptions o;
  o.covisibility_min_shared = 3;
  TrackerMap map(o);
  const auto a = map.addKeyframe(makeKf(0, std::vector<std::int64_t>(6, -1)));
  // Keyframe 1 sees points 0-3 of keyframe 0 and creates 2 of its own.
  std::vector<std::int64_t> ids1(a.begin(), a.begin() + 4);
  ids1.resize(6, -1);
  const auto b = map.addKeyframe(makeKf(1, ids1, 1.0));
  // Keyframe 2 sees 4 of keyframe 1's points: one it created and three of keyframe 0's.
  map.addKeyframe(makeKf(2, {b[1], b[2], b[3], b[4], -1, -1}, 2.0));
  const Eigen::Isometry3d T_world_1 = map.keyframe(1)->T_world_camera;

  ASSERT_TRUE(map.removeKeyframe(1));
  EXPECT_EQ(map.keyframe(1), nullptr);
  EXPECT_EQ(map.numRemovedKeyframes(), 1u);
  EXPECT_EQ(map.point(b[5]), nullptr);               // seen only by keyframe 1
  EXPECT_EQ(map.point(b[4])->first_keyframe_id, 2);  // created by 1, also seen by 2
  EXPECT_EQ(map.point(a[0])->observations.count(1), 0u);
  ASSERT_TRUE(map.keyframePose(1).has_value());
  EXPECT_TRUE(map.keyframePose(1)->isApprox(T_world_1, 1e-12));
  // Attached to keyframe 2 (4 shared points with each of 0 and 2; ties go to the newer one).
  Eigen::Isometry3d T2 = map.keyframe(2)->T_world_camera;
  T2.translation().y() += 0.5;
  map.applyKeyframePoses({{2, T2}});
  EXPECT_NEAR(map.keyframePose(1)->translation().y(), 0.5, 1e-12);
  EXPECT_NEAR(map.keyframePose(1)->translation().x(), 1.0, 1e-12);
  EXPECT_NEAR(map.point(b[4])->p_world_m.y(), 0.5, 1e-12);  // moves with its new first keyframe
  // Keyframe 2 removed too: keyframe 1's pose moves on to keyframe 2's parent (keyframe 0).
  ASSERT_TRUE(map.removeKeyframe(2));
  const Eigen::Isometry3d T_world_1_now = *map.keyframePose(1);
  Eigen::Isometry3d T0 = map.keyframe(0)->T_world_camera;
  T0.translation().z() += 0.25;
  map.applyKeyframePoses({{0, T0}});
  EXPECT_NEAR(map.keyframePose(1)->translation().z(), T_world_1_now.translation().z() + 0.25, 1e-12);
  EXPECT_NEAR(map.keyframePose(2)->translation().z(), 0.25, 1e-12);
  // The last keyframe stays; unknown ids and a cleared map answer nothing.
  EXPECT_FALSE(map.removeKeyframe(0));
  EXPECT_FALSE(map.removeKeyframe(7));
  EXPECT_FALSE(map.keyframePose(7).has_value());
  map.clear();
  EXPECT_FALSE(map.keyframePose(1).has_value());
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
