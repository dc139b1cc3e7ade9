#include <gtest/gtest.h>

#include <stdexcept>

#include <opencv2/core.hpp>

#include "dypho/mapping/view_evaluation.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

/// A textured input frame (so that SSIM has structure to compare) and its depth.
struct Frame {
  cv::Mat bgr, depth_m;
};

Frame texturedFrame() {
  Frame f;
  f.bgr.create(120, 160, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(f.bgr, cv::RNG::UNIFORM, 0, 256);
  f.depth_m = cv::Mat(120, 160, CV_32FC1, cv::Scalar(2.0f));
  return f;
}

/// A render that reproduces the frame exactly, fully opaque.
RenderedView perfectRender(const Frame& f) {
  RenderedView v;
  v.bgr = f.bgr.clone();
  v.depth_m = f.depth_m.clone();
  v.alpha = cv::Mat(f.bgr.size(), CV_32FC1, cv::Scalar(1.0f));
  return v;
}

TEST(ViewEvaluation, PerfectRenderScoresPerfectly) {
  const Frame f = texturedFrame();
  const ViewScore s = scoreView(perfectRender(f), f.bgr, f.depth_m, cv::Mat(), ViewEvaluationOptions());
  EXPECT_EQ(s.static_pixels, 160u * 120u);
  EXPECT_GE(s.psnr_db, 99.0);  // MSE floor 1e-10: 100 dB
  EXPECT_NEAR(s.ssim, 1.0, 1e-4);
  EXPECT_DOUBLE_EQ(s.coverage, 1.0);
  EXPECT_DOUBLE_EQ(s.depth_l1_m, 0.0);
}

TEST(ViewEvaluation, HolesCountAgainstCoverageAndColour) {
  const Frame f = texturedFrame();
  RenderedView v = perfectRender(f);
  // The left half was never mapped: black, transparent, no depth.
  const cv::Rect left(0, 0, 80, 120);
  v.bgr(left).setTo(cv::Scalar::all(0));
  v.alpha(left).setTo(0.0f);
  v.depth_m(left).setTo(0.0f);
  const ViewScore s = scoreView(v, f.bgr, f.depth_m, cv::Mat(), ViewEvaluationOptions());
  EXPECT_NEAR(s.coverage, 0.5, 1e-9);
  EXPECT_LT(s.psnr_db, 10.0);  // half the pixels off by the random texture (mean square ~ 0.33 / 2)
  EXPECT_LT(s.ssim, 0.6);
  EXPECT_DOUBLE_EQ(s.depth_l1_m, 0.0);  // depth compared only where both exist
}

TEST(ViewEvaluation, DepthErrorIsTheMeanAbsoluteDifference) {
  const Frame f = texturedFrame();
  RenderedView v = perfectRender(f);
  v.depth_m += 0.05f;
  const ViewScore s = scoreView(v, f.bgr, f.depth_m, cv::Mat(), ViewEvaluationOptions());
  EXPECT_NEAR(s.depth_l1_m, 0.05, 1e-6);
}

TEST(ViewEvaluation, TheDilatedMaskKeepsAMoversRimOut) {
  const Frame f = texturedFrame();
  RenderedView v = perfectRender(f);
  // A person in the input that the map (rightly) does not have: the render differs inside the
  // box and on a 3 px rim the mask missed.
  const cv::Rect person(60, 30, 30, 60), rim(57, 27, 36, 66);
  cv::Mat mask = cv::Mat::zeros(f.bgr.size(), CV_8UC1);
  mask(person).setTo(255);
  v.bgr(rim).setTo(cv::Scalar(255, 0, 255));
  ViewEvaluationOptions options;  // 5 px dilation
  const ViewScore dilated = scoreView(v, f.bgr, f.depth_m, mask, options);
  EXPECT_GE(dilated.psnr_db, 99.0);
  EXPECT_LT(dilated.static_pixels, 160u * 120u - 30u * 60u);
  options.mask_dilation_px = 0;
  const ViewScore raw = scoreView(v, f.bgr, f.depth_m, mask, options);
  EXPECT_LT(raw.psnr_db, 30.0);
  EXPECT_EQ(raw.static_pixels, 160u * 120u - 30u * 60u);
  EXPECT_EQ(cv::countNonZero(mask), 30 * 60);  // the caller's mask is not dilated in place
}

TEST(ViewEvaluation, KeyframesAndNovelViewsAreSummarisedApart) {
  std::vector<ViewScore> views(3);
  views[0] = {1, true, 100, 30.0, 0.9, 0.01, 1.0};
  views[1] = {2, false, 100, 20.0, 0.7, 0.03, 0.8};
  views[2] = {3, false, 100, 24.0, 0.8, 0.05, 0.9};
  const ViewEvaluation ev = summarizeViews(views);
  EXPECT_EQ(ev.all.views, 3u);
  EXPECT_NEAR(ev.all.psnr_db, 74.0 / 3.0, 1e-9);
  EXPECT_EQ(ev.keyframes.views, 1u);
  EXPECT_NEAR(ev.keyframes.psnr_db, 30.0, 1e-9);
  EXPECT_EQ(ev.novel.views, 2u);
  EXPECT_NEAR(ev.novel.psnr_db, 22.0, 1e-9);
  EXPECT_NEAR(ev.novel.coverage, 0.85, 1e-9);
  EXPECT_NE(ev.report().find("novel"), std::string::npos);
}

TEST(ViewEvaluation, MismatchedInputsAndBadOptionsAreRefused) {
  const Frame f = texturedFrame();
  const RenderedView v = perfectRender(f);
  cv::Mat small_mask = cv::Mat::zeros(60, 80, CV_8UC1);
  EXPECT_THROW(scoreView(v, f.bgr, f.depth_m, small_mask, ViewEvaluationOptions()), std::invalid_argument);
  cv::Mat depth_mm;
  f.depth_m.convertTo(depth_mm, CV_16UC1, 1000.0);
  EXPECT_THROW(scoreView(v, f.bgr, depth_mm, cv::Mat(), ViewEvaluationOptions()), std::invalid_argument);
  ViewEvaluationOptions bad;
  bad.every_nth_frame = 0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = ViewEvaluationOptions();
  bad.coverage_min_alpha = 0.f;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
