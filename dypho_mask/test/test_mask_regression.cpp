// Accuracy regression of the flow + background mask (no network) on a short synthetic sequence
// with ground-truth masks, the camera's ground-truth relative pose given as the prior.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "dypho/mask/dynamic_masker.h"
#include "dypho/tools/synthetic_scene.h"

using namespace dypho;

TEST(MaskRegression, HalfsphereTwoPeopleWithGroundTruthPosePrior) {
  tools::SynthOptions so;
  so.frames = 30;
  so.people = 2;
  so.seed = 3;
  so.motion = tools::SynthMotion::kHalfsphere;
  const tools::SyntheticScene scene(so);
  mask::DynamicMasker masker{mask::DynamicMaskOptions()};
  double inter = 0, uni = 0, false_dyn = 0, static_px = 0;
  Eigen::Isometry3d T_world_prev = Eigen::Isometry3d::Identity();
  for (int i = 0; i < so.frames; ++i) {
    const tools::SynthFrame f = scene.render(i);
    mask::MaskPrior prior;
    if (i >= 1) prior.T_prev_cur = T_world_prev.inverse() * f.T_world_camera;
    T_world_prev = f.T_world_camera;
    const mask::MaskResult r = masker.compute(f.frame, prior);
    ASSERT_EQ(r.mask.size(), f.mask_gt.size());
    if (i < 5) continue;  // warm-up: the background model needs a few frames (frames 0..4 skipped)
    const cv::Mat gt = f.mask_gt > 0, m = r.mask > 0;
    inter += cv::countNonZero(gt & m);
    uni += cv::countNonZero(gt | m);
    false_dyn += cv::countNonZero(m & ~gt);
    static_px += cv::countNonZero(~gt);
  }
  const double iou = inter / uni, false_share = false_dyn / static_px;
  // Measured (Release, OpenCV 4.6, bookworm): IoU 0.865, false-dynamic 1.58 % over frames 5..29.
  // Bounds = the acceptance bounds (IoU >= 0.85, false-dynamic <= 2 %), i.e. a margin of
  // 0.015 IoU and 0.42 points below what is measured; the test fails on any regression beyond it.
  EXPECT_GE(iou, 0.85);
  EXPECT_LE(false_share, 0.02);
  RecordProperty("iou", std::to_string(iou));
  RecordProperty("false_dynamic", std::to_string(false_share));
}
