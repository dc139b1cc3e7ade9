// Accuracy regression of the flow + background mask (no network) on short synthetic sequences
// with ground-truth masks, the camera's ground-truth relative pose given as the prior: two camera
// motions and several scene seeds (people placement, texture, noise), so that a change that only
// helps one sequence does not pass.
#include <gtest/gtest.h>

#include <string>
#include <tuple>

#include <opencv2/core.hpp>

#include "dypho/mask/dynamic_masker.h"
#include "dypho/tools/synthetic_scene.h"

using namespace dypho;

namespace DYPHO_UNITY_ID {

struct Scores {
  double iou = 0.0;
  double false_share = 0.0;
  double missed_share = 0.0;  ///< of the people's pixels
};

struct SequenceSetup {
  int people = 2;
  mask::DynamicMaskOptions options;
};

/// Pooled IoU and false-dynamic share over frames 5..frames-1 (frames 0..4 are the warm-up of the
/// background model). From frame `catch_up_from` on (-1 = never) every frame is masked in
/// catch-up mode, as by a live caller that fell behind.
Scores runSequence(tools::SynthMotion motion, std::uint32_t seed, int frames, int catch_up_from = -1,
                   const SequenceSetup& setup = SequenceSetup()) {
  tools::SynthOptions so;
  so.frames = frames;
  so.people = setup.people;
  so.seed = seed;
  so.motion = motion;
  const tools::SyntheticScene scene(so);
  mask::DynamicMasker masker{setup.options};
  double inter = 0, uni = 0, false_dyn = 0, static_px = 0, missed = 0, dynamic_px = 0;
  Eigen::Isometry3d T_world_prev = Eigen::Isometry3d::Identity();
  for (int i = 0; i < so.frames; ++i) {
    const tools::SynthFrame f = scene.render(i);
    mask::MaskPrior prior;
    if (i >= 1) prior.T_prev_cur = T_world_prev.inverse() * f.T_world_camera;
    prior.catching_up = catch_up_from >= 0 && i >= catch_up_from;
    T_world_prev = f.T_world_camera;
    const mask::MaskResult r = masker.compute(f.frame, prior);
    EXPECT_EQ(r.mask.size(), f.mask_gt.size());
    if (i < 5) continue;
    const cv::Mat gt = f.mask_gt > 0, m = r.mask > 0;
    inter += cv::countNonZero(gt & m);
    uni += cv::countNonZero(gt | m);
    false_dyn += cv::countNonZero(m & ~gt);
    static_px += cv::countNonZero(~gt);
    missed += cv::countNonZero(gt & ~m);
    dynamic_px += cv::countNonZero(gt);
  }
  return {inter / uni, false_dyn / static_px, missed / dynamic_px};
}

class MaskRegression : public ::testing::TestWithParam<std::tuple<tools::SynthMotion, int>> {};

TEST_P(MaskRegression, MeetsTheIssueBoundsWithGroundTruthPosePrior) {
  const auto [motion, seed] = GetParam();
  const Scores s = runSequence(motion, static_cast<std::uint32_t>(seed), 40);
  // Bounds = the issue's acceptance bounds (IoU >= 0.85, false-dynamic <= 2 % of static pixels);
  // never loosened. Measured (Release, OpenCV 4.6, bookworm; deterministic), IoU / false-dynamic:
  // halfsphere seed 1: 0.945 / 1.40 %, seed 3: 0.856 / 0.82 %, seed 5: 0.861 / 1.11 %;
  // xyz seed 2: 0.928 / 1.13 %. Seeds 3 and 5 (a person in view from the first frame, walking
  // towards the camera) leave the least margin: 0.006 and 0.011 IoU.
  EXPECT_GE(s.iou, 0.85);
  EXPECT_LE(s.false_share, 0.02);
  RecordProperty("iou", std::to_string(s.iou));
  RecordProperty("false_dynamic", std::to_string(s.false_share));
  std::printf("IoU %.3f false-dynamic %.2f %%\n", s.iou, 100.0 * s.false_share);
}

// The same bounds while a live caller catches up (DynamicMaskOptions::catch_up_frames_waiting):
// a machine that falls behind gets a cheaper mask, not one worse than the issue allows. Catch-up
// from frame 10 on, once the background model is established.
TEST_P(MaskRegression, MeetsTheIssueBoundsWhileCatchingUp) {
  const auto [motion, seed] = GetParam();
  const Scores s = runSequence(motion, static_cast<std::uint32_t>(seed), 40, 10);
  EXPECT_GE(s.iou, 0.85);
  EXPECT_LE(s.false_share, 0.02);
  std::printf("catching up: IoU %.3f false-dynamic %.2f %%\n", s.iou, 100.0 * s.false_share);
}

// DynamicMaskOptions::moving_permanence_frames (off by default): a camera on a half sphere with 8
// people crossing, who turn round on the spot at the end of their short stretches. With 30 frames
// of permanence the people who stand stay masked: fewer of their pixels are missed. Measured
// (frames 5-69, ground-truth pose prior): missed 25.7 -> 22.5 %, IoU 0.687 -> 0.735, false-dynamic
// 7.77 -> 5.06 %; the bound asks for one point of the missed share.
TEST(MaskRegressionCrowd, MovingPermanenceKeepsPeopleWhoStand) {
  SequenceSetup off;
  off.people = 8;
  SequenceSetup on = off;
  on.options.moving_permanence_frames = 30;
  const Scores without = runSequence(tools::SynthMotion::kHalfsphere, 1, 70, -1, off);
  const Scores with = runSequence(tools::SynthMotion::kHalfsphere, 1, 70, -1, on);
  std::printf("missed %.1f -> %.1f %%, IoU %.3f -> %.3f, false-dynamic %.2f -> %.2f %%\n", 100.0 * without.missed_share,
              100.0 * with.missed_share, without.iou, with.iou, 100.0 * without.false_share, 100.0 * with.false_share);
  EXPECT_LT(with.missed_share, without.missed_share - 0.01);
  EXPECT_GT(with.iou, without.iou);
}

INSTANTIATE_TEST_SUITE_P(Sequences, MaskRegression,
                         ::testing::Values(std::make_tuple(tools::SynthMotion::kHalfsphere, 1),
                                           std::make_tuple(tools::SynthMotion::kHalfsphere, 3),
                                           std::make_tuple(tools::SynthMotion::kHalfsphere, 5),
                                           std::make_tuple(tools::SynthMotion::kXyz, 2)));
}  // namespace DYPHO_UNITY_ID
