#include <cmath>
#include <iostream>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "dypho/tracking/feature_preparer.h"
#include "dypho/tracking/rgbd_odometry.h"
#include "dypho/tracking/tracking_stage.h"
#include "synthetic_scene.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

constexpr Timestamp kDt = 33'000'000;  // 30 Hz

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

void expectFinite(const TrackingResult& r) { EXPECT_TRUE(r.T_world_camera.matrix().allFinite()) << r.message; }

TEST(RgbdOdometry, FirstGoodFrameIsKeyframeZeroAtIdentity) {
  RgbdOdometry odo{TrackingOptions()};
  const TrackingResult r = odo.track(test::planarFrame(test::texturedImage(21), 2.0, kDt), {});
  EXPECT_EQ(r.state, TrackingState::kOk) << r.message;
  ASSERT_TRUE(r.is_keyframe);
  ASSERT_NE(r.keyframe, nullptr);
  EXPECT_EQ(r.keyframe->id, 0);
  EXPECT_TRUE(r.T_world_camera.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_FALSE(r.pose_covariance.valid) << "the first keyframe defines the map: nothing to be uncertain of";
  EXPECT_GT(r.keyframe->keypoints.size(), 500u);
  for (const auto& kp : r.keyframe->keypoints) {
    EXPECT_NEAR(kp.depth_m, 2.0f, 1e-6f);
    EXPECT_GE(kp.map_point_id, 0);
  }
}

/// A pure image shift on a wall at 2 m is a camera translation of -shift * z / f.
/// Bound 5 mm: a 1 px error in the estimated shift is 2 / 525 = 3.8 mm; with hundreds of exact
/// matches the error must be far below one pixel.
TEST(RgbdOdometry, TracksASyntheticTranslation) {
  RgbdOdometry odo{TrackingOptions()};
  const cv::Mat img = test::texturedImage(22);
  ASSERT_EQ(odo.track(test::planarFrame(img, 2.0, kDt), {}).state, TrackingState::kOk);
  const int shift = 10;
  const TrackingResult r = odo.track(test::planarFrame(test::shifted(img, shift, 0), 2.0, 2 * kDt), {});
  ASSERT_EQ(r.state, TrackingState::kOk) << r.message;
  EXPECT_FALSE(r.is_keyframe);  // 3.8 cm, no rotation, well tracked
  EXPECT_EQ(r.keyframe, nullptr);
  EXPECT_NEAR(r.T_world_camera.translation().x(), -shift * 2.0 / 525.0, 0.005);
  EXPECT_NEAR(r.T_world_camera.translation().y(), 0.0, 0.005);
  EXPECT_GT(r.num_inliers, 300);
  EXPECT_TRUE(r.message.empty()) << r.message;
  // The frame's covariance: exact matches on a wall at 2 m leave the centre to a few millimetres
  // at most (a single plane at one depth is the shift-turn ambiguity's worst case, yet 300
  // matches over the whole view fix it); bound 1 cm, and the error itself within 3 sigma.
  ASSERT_TRUE(r.pose_covariance.valid);
  const double sigma_m = r.pose_covariance.maxPositionSigmaM();
  std::cout << "synthetic translation: position sigma " << sigma_m * 1e3 << " mm\n";
  EXPECT_GT(sigma_m, 0.0);
  EXPECT_LT(sigma_m, 0.01);
  EXPECT_LT(std::abs(r.T_world_camera.translation().x() + shift * 2.0 / 525.0), 3.0 * sigma_m + 1e-4);
}

/// Features prepared ahead by another FeaturePreparer (what TrackingNodelet does on its own
/// thread) give the tracker exactly what it prepares itself: same poses, to the bit, on a shifted
/// and masked sequence with keyframes. Features prepared for another stamp are not used.
TEST(RgbdOdometry, FeaturesPreparedAheadGiveTheSameResult) {
  const TrackingOptions options;
  RgbdOdometry inline_odo{options}, prepared_odo{options};
  FeaturePreparer preparer{options};
  const cv::Mat img = test::texturedImage(24);
  cv::Mat mask = cv::Mat::zeros(img.size(), CV_8UC1);
  mask(cv::Rect(200, 120, 120, 200)).setTo(255);
  int keyframes = 0, used_stale = 0;
  for (int i = 0; i < 12; ++i) {
    const RgbdFrame frame = test::planarFrame(test::shifted(img, 4 * i, i), 2.0, (i + 1) * kDt);
    const TrackingResult a = inline_odo.track(frame, mask);
    PreparedFeatures prepared = preparer.prepare(frame, mask);
    ASSERT_TRUE(prepared.valid);
    EXPECT_EQ(prepared.stamp_ns, frame.stamp_ns);
    if (i == 5) {  // prepared for another frame: the tracker prepares its own
      prepared.stamp_ns += 1;
      prepared.features = FrameFeatures();
      ++used_stale;
    }
    const TrackingResult b = prepared_odo.track(frame, mask, MaskJudgement::kUnknown, &prepared);
    ASSERT_EQ(a.state, TrackingState::kOk) << a.message;
    EXPECT_EQ(b.state, a.state);
    EXPECT_EQ(b.is_keyframe, a.is_keyframe);
    EXPECT_EQ(b.num_features, a.num_features);
    EXPECT_EQ(b.num_inliers, a.num_inliers);
    EXPECT_TRUE(b.T_world_camera.matrix() == a.T_world_camera.matrix()) << "frame " << i;
    keyframes += a.is_keyframe ? 1 : 0;
  }
  EXPECT_GE(keyframes, 2);  // the sequence leaves the first keyframe's view: keyframe paths ran too
  EXPECT_EQ(used_stale, 1);
}

TEST(FeaturePreparer, BadInputIsInvalidNeverThrows) {
  FeaturePreparer preparer{TrackingOptions()};
  RgbdFrame frame = test::planarFrame(test::texturedImage(25), 2.0, kDt);
  const cv::Mat wrong_mask(10, 10, CV_8UC1, cv::Scalar(0));
  EXPECT_FALSE(preparer.prepare(frame, wrong_mask).valid);
  EXPECT_FALSE(checkTrackingInput(frame, wrong_mask).empty());
  frame.depth_m = cv::Mat();
  EXPECT_FALSE(preparer.prepare(frame, {}).valid);
  EXPECT_TRUE(contains(checkTrackingInput(frame, {}), "depth"));
}

TEST(RgbdOdometry, BadInputGivesStateAndMessageNeverThrows) {
  RgbdOdometry odo{TrackingOptions()};
  const cv::Mat img = test::texturedImage(23);
  Timestamp t = kDt;

  // All-zero depth before initialisation.
  RgbdFrame f = test::planarFrame(img, 0.0, t += kDt);
  TrackingResult r = odo.track(f, {});
  EXPECT_EQ(r.state, TrackingState::kNotInitialized);
  EXPECT_TRUE(contains(r.message, "no valid depth")) << r.message;
  expectFinite(r);

  // NaN depth everywhere.
  f = test::planarFrame(img, std::numeric_limits<double>::quiet_NaN(), t += kDt);
  r = odo.track(f, {});
  EXPECT_EQ(r.state, TrackingState::kNotInitialized);
  EXPECT_TRUE(contains(r.message, "no valid depth")) << r.message;
  expectFinite(r);

  // Everything masked dynamic.
  f = test::planarFrame(img, 2.0, t += kDt);
  r = odo.track(f, cv::Mat(img.size(), CV_8UC1, cv::Scalar(255)));
  EXPECT_EQ(r.state, TrackingState::kNotInitialized);
  EXPECT_TRUE(contains(r.message, "masked")) << r.message;
  EXPECT_DOUBLE_EQ(r.masked_fraction, 1.0);

  // Black image.
  f = test::planarFrame(cv::Mat(img.size(), CV_8UC1, cv::Scalar(0)), 2.0, t += kDt);
  r = odo.track(f, {});
  EXPECT_EQ(r.state, TrackingState::kNotInitialized);
  EXPECT_TRUE(contains(r.message, "textureless")) << r.message;

  // Wrong depth type (16-bit raw).
  f = test::planarFrame(img, 2.0, t += kDt);
  f.depth_m = cv::Mat(img.size(), CV_16UC1, cv::Scalar(10000));
  r = odo.track(f, {});
  EXPECT_EQ(r.state, TrackingState::kNotInitialized);
  EXPECT_TRUE(contains(r.message, "CV_32FC1")) << r.message;

  // Now initialise, then a black frame: LOST, last pose kept.
  r = odo.track(test::planarFrame(img, 2.0, t += kDt), {});
  ASSERT_EQ(r.state, TrackingState::kOk) << r.message;
  r = odo.track(test::planarFrame(cv::Mat(img.size(), CV_8UC1, cv::Scalar(0)), 2.0, t += kDt), {});
  EXPECT_EQ(r.state, TrackingState::kLost);
  EXPECT_FALSE(r.message.empty());
  EXPECT_FALSE(r.is_keyframe);
  EXPECT_TRUE(r.T_world_camera.isApprox(Eigen::Isometry3d::Identity()));
  // Zero depth while tracking: LOST too.
  r = odo.track(test::planarFrame(img, 0.0, t += kDt), {});
  EXPECT_EQ(r.state, TrackingState::kLost);
  EXPECT_TRUE(contains(r.message, "no valid depth")) << r.message;
  // Recovers on the next good frame against the same keyframe.
  r = odo.track(test::planarFrame(img, 2.0, t += kDt), {});
  EXPECT_EQ(r.state, TrackingState::kOk) << r.message;

  // Stamp going backwards: reset.
  r = odo.track(test::planarFrame(img, 2.0, t - 5 * kDt), {});
  EXPECT_EQ(r.state, TrackingState::kNotInitialized);
  EXPECT_TRUE(contains(r.message, "backwards")) << r.message;
  expectFinite(r);
  // The next frame starts a new world with a new keyframe id (ids never repeat).
  r = odo.track(test::planarFrame(img, 2.0, t - 4 * kDt), {});
  EXPECT_EQ(r.state, TrackingState::kOk) << r.message;
  ASSERT_TRUE(r.is_keyframe);
  EXPECT_EQ(r.keyframe->id, 1);
}

TEST(RgbdOdometry, ReinitialisesAfterMaxLostFrames) {
  TrackingOptions o;
  o.max_lost_frames = 3;
  RgbdOdometry odo(o);
  Timestamp t = kDt;
  ASSERT_EQ(odo.track(test::planarFrame(test::texturedImage(24), 2.0, t += kDt), {}).state, TrackingState::kOk);
  // A completely different scene cannot be registered to the keyframe.
  const RgbdFrame other = test::planarFrame(test::texturedImage(99), 2.0, 0);
  for (int i = 1; i < 3; ++i) {
    RgbdFrame f = other;
    f.stamp_ns = t += kDt;
    const TrackingResult r = odo.track(f, {});
    EXPECT_EQ(r.state, TrackingState::kLost) << "frame " << i << ": " << r.message;
  }
  RgbdFrame f = other;
  f.stamp_ns = t += kDt;
  const TrackingResult r = odo.track(f, {});
  EXPECT_EQ(r.state, TrackingState::kOk);
  EXPECT_TRUE(r.is_keyframe);
  EXPECT_TRUE(contains(r.message, "re-initialised")) << r.message;
  // The new keyframe's pose is a guess (the last good pose): not anchored to the map.
  EXPECT_FALSE(r.anchored);
  f.stamp_ns = t += kDt;
  const TrackingResult next = odo.track(f, {});
  EXPECT_EQ(next.state, TrackingState::kOk) << next.message;
  EXPECT_FALSE(next.anchored) << "still in the re-initialised segment";
  // Back in the first scene: found again against keyframe 0, anchored again.
  const TrackingResult back = odo.track(test::planarFrame(test::texturedImage(24), 2.0, t += kDt), {});
  EXPECT_EQ(back.state, TrackingState::kOk) << back.message;
  EXPECT_TRUE(back.relocalized) << back.message;
  EXPECT_TRUE(back.anchored) << back.message;
}

// The stage hands a re-initialised pose on as not anchored, so that neither the map nor the
// published pose takes a guess for a measurement (the mask may still use the motion).
TEST(TrackingStage, PosesOfAReinitialisedSegmentAreNotAnchored) {
  TrackingOptions o;
  o.max_lost_frames = 2;
  TrackingStage stage(o);
  Timestamp t = kDt;
  ASSERT_TRUE(stage.process(test::planarFrame(test::texturedImage(24), 2.0, t += kDt), {}).pose.trusted);
  const RgbdFrame other = test::planarFrame(test::texturedImage(99), 2.0, 0);
  TrackingOutput out;
  for (int i = 0; i < 2; ++i) {
    RgbdFrame f = other;
    f.stamp_ns = t += kDt;
    out = stage.process(f, {});
  }
  ASSERT_TRUE(contains(out.result.message, "re-initialised")) << out.result.message;
  EXPECT_EQ(out.result.state, TrackingState::kOk);
  EXPECT_TRUE(out.pose.trusted) << "tracked: the motion within the segment is right";
  EXPECT_FALSE(out.pose.anchored) << "but its start is a guess";
  const TrackingOutput back = stage.process(test::planarFrame(test::texturedImage(24), 2.0, t += kDt), {});
  EXPECT_TRUE(back.pose.trusted) << back.result.message;
  EXPECT_TRUE(back.pose.anchored) << back.result.message;
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
