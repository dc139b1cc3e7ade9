// MaskStage's hand-overs from tracking. Moving points: the features the static check found
// carried along with people the mask missed are grown over the surface they lie on in the next
// mask (DynamicMaskOptions::moving_point_seeds). Catch-up mode, and the wait for the previous
// frame's pose.
#include <gtest/gtest.h>

#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/mask/mask_stage.h"

using namespace dypho;
using namespace dypho::mask;

namespace DYPHO_UNITY_ID {

constexpr Timestamp kFrameNs = 33'333'333;
const cv::Rect kPerson(100, 60, 60, 120);  // full-res px

// A static camera before a textured wall at 3 m. Where the person will stand the depth is missing
// on frames 0 and 1 (the background model never learns it); on frame 2 a person as textured as
// the wall stands there at 1.5 m. Neither the flow (the image does not change) nor the
// consistency test (no background value there) can see the person.
RgbdFrame frameAt(int i) {
  RgbdFrame f;
  f.stamp_ns = (i + 1) * kFrameNs;
  f.camera.fx = f.camera.fy = 262.5;
  f.camera.cx = 159.5;
  f.camera.cy = 119.5;
  f.camera.width = 320;
  f.camera.height = 240;
  f.bgr.create(240, 320, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(f.bgr, cv::RNG::UNIFORM, 0, 256);
  f.depth_m = cv::Mat(240, 320, CV_32FC1, cv::Scalar(3.0f));
  f.depth_m(kPerson).setTo(i < 2 ? 0.0f : 1.5f);
  return f;
}

/// The person's centre as tracking would report it, in the camera optical frame [m].
cv::Point3f personCentre(const CameraIntrinsics& c) {
  const double u = kPerson.x + kPerson.width / 2.0, v = kPerson.y + kPerson.height / 2.0, z = 1.5;
  return {static_cast<float>((u - c.cx) / c.fx * z), static_cast<float>((v - c.cy) / c.fy * z), static_cast<float>(z)};
}

/// Share of the person masked on frame 2, with `points` (seen at `seen_ns`) handed over after frame 1.
double personCoverage(bool seeds, const std::vector<cv::Point3f>& points, Timestamp seen_ns) {
  DynamicMaskOptions options;
  options.moving_point_seeds = seeds;
  MaskStage stage(options);
  for (int i = 0; i < 2; ++i) {
    PoseUpdate still{frameAt(i).stamp_ns, Eigen::Isometry3d::Identity(), true, false};
    stage.process(frameAt(i));
    stage.observePose(still);
  }
  stage.observeMovingPoints({seen_ns, points});
  const MaskResult result = stage.process(frameAt(2));
  EXPECT_FALSE(result.mask.empty());
  if (result.mask.empty()) return 0.0;
  return static_cast<double>(cv::countNonZero(result.mask(kPerson))) / kPerson.area();
}

// Bounds: the seeded person is covered but for the mask's clean-up at its outline (> 90 %); the
// unseeded one is missed entirely but for the margin grown from the wall's side (< 30 %).
TEST(MovingPointSeeds, GrowOverThePersonTheMaskMissed) {
  const CameraIntrinsics camera = frameAt(0).camera;
  const std::vector<cv::Point3f> points{personCentre(camera)};
  const Timestamp seen_on_frame_1 = frameAt(1).stamp_ns;
  EXPECT_GT(personCoverage(true, points, seen_on_frame_1), 0.9);
  EXPECT_LT(personCoverage(true, {}, seen_on_frame_1), 0.3);       // nothing handed over
  EXPECT_LT(personCoverage(false, points, seen_on_frame_1), 0.3);  // seeds switched off
}

// Points older than MaskStageOptions::moving_points_max_age_s (0.1 s), or at a depth the current
// one does not have, say nothing about this frame.
TEST(MovingPointSeeds, IgnoreOldPointsAndOtherSurfaces) {
  const CameraIntrinsics camera = frameAt(0).camera;
  EXPECT_LT(personCoverage(true, {personCentre(camera)}, frameAt(2).stamp_ns - 200'000'000), 0.3);
  cv::Point3f farther = personCentre(camera) * (2.5f / 1.5f);  // same pixel, 1 m behind the person
  EXPECT_LT(personCoverage(true, {farther}, frameAt(1).stamp_ns), 0.3);
}

// The stage's catch-up mode (DynamicMaskOptions::catch_up_frames_waiting): a frame is masked in it
// when the caller holds at least that many frames behind it, counted; 0 switches it off; offline
// callers (frames_waiting 0) never enter it. The mask is still produced.
TEST(MaskStageCatchUp, FramesWaitingBehindAFramePutItInCatchUpMode) {
  const auto caught_up = [](int catch_up_frames_waiting, const std::vector<std::size_t>& waiting) {
    DynamicMaskOptions options;
    options.catch_up_frames_waiting = catch_up_frames_waiting;
    MaskStage stage(options);
    for (std::size_t i = 0; i < waiting.size(); ++i) {
      const MaskResult result = stage.process(frameAt(static_cast<int>(i)), waiting[i]);
      EXPECT_FALSE(result.dropped);
      if (i > 0) {
        EXPECT_FALSE(result.mask.empty()) << "frame " << i;
      }
    }
    return stage.stats().frames_caught_up;
  };
  EXPECT_EQ(caught_up(1, {0, 0, 0}), 0u);
  EXPECT_EQ(caught_up(1, {0, 1, 2}), 2u);
  EXPECT_EQ(caught_up(2, {0, 1, 2}), 1u);
  EXPECT_EQ(caught_up(0, {0, 1, 2}), 0u);
  DynamicMaskOptions bad;
  bad.catch_up_frames_waiting = -1;
  EXPECT_THROW(MaskStage{bad}, std::invalid_argument);
}
// Live (MaskStageOptions::previous_pose_wait_s): a frame's mask waits for the pose of the frame
// masked before it, which tracking hands on a few milliseconds later, so that its ego-motion prior
// is fresh. Not when frames wait behind it (the graph is behind), not with 0, and a pose that
// never comes costs one bounded wait. The pose arrives 30 ms after the frame from another thread.
struct PoseWait {
  std::size_t fresh = 0;      ///< frames with a fresh prior among the last one
  std::size_t timed_out = 0;  ///< waits in vain
};
PoseWait lastFrameWithLatePose(double wait_s, std::size_t frames_waiting, bool pose_comes) {
  MaskStageOptions stage_options;
  stage_options.previous_pose_wait_s = wait_s;
  MaskStage stage(DynamicMaskOptions(), stage_options);
  const auto still = [](int i) { return PoseUpdate{frameAt(i).stamp_ns, Eigen::Isometry3d::Identity(), true, false}; };
  for (int i = 0; i < 3; ++i) {  // offline: each pose is there before the next frame
    stage.process(frameAt(i));
    stage.observePose(still(i));
  }
  stage.process(frameAt(3));
  const std::size_t fresh_before = stage.stats().frames_with_fresh_prior;
  std::thread tracking([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    if (pose_comes) stage.observePose(still(3));
  });
  const MaskResult result = stage.process(frameAt(4), frames_waiting);
  tracking.join();
  EXPECT_FALSE(result.mask.empty());
  return {stage.stats().frames_with_fresh_prior - fresh_before, stage.stats().pose_waits_timed_out};
}

TEST(MaskStagePreviousPose, AFrameWaitsForThePreviousFramesPoseUnlessFramesWaitBehindIt) {
  const PoseWait waited = lastFrameWithLatePose(1.0, 0, true);
  EXPECT_EQ(waited.fresh, 1u);
  EXPECT_EQ(waited.timed_out, 0u);
  EXPECT_EQ(lastFrameWithLatePose(0.0, 0, true).fresh, 0u);  // never waits: predicted from older poses
  EXPECT_EQ(lastFrameWithLatePose(1.0, 1, true).fresh, 0u);  // behind: does not wait
  const PoseWait in_vain = lastFrameWithLatePose(0.005, 0, false);
  EXPECT_EQ(in_vain.fresh, 0u);
  EXPECT_EQ(in_vain.timed_out, 1u);
  MaskStageOptions bad;
  bad.previous_pose_wait_s = -0.01;
  EXPECT_THROW((MaskStage{DynamicMaskOptions(), bad}), std::invalid_argument);
  bad.previous_pose_wait_s = 2.0;
  EXPECT_THROW((MaskStage{DynamicMaskOptions(), bad}), std::invalid_argument);
}
}  // namespace DYPHO_UNITY_ID
