#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "dypho/tracking/orb_extractor.h"
#include "synthetic_scene.h"

namespace dypho {
namespace tracking {
namespace {

TEST(OrbExtractor, SpreadsKeypointsOverTheImage) {
  OrbExtractor extractor{TrackingOptions()};
  const cv::Mat img = test::texturedImage(3);
  const OrbFeatures f = extractor.extract(img, cv::Mat());
  ASSERT_EQ(static_cast<int>(f.keypoints.size()), f.descriptors.rows);
  EXPECT_EQ(f.descriptors.cols, 32);
  // The budget is 1000; a richly textured image must come close (allowing for cells where
  // non-maximum suppression leaves fewer corners than the round-robin asks for).
  EXPECT_GE(f.keypoints.size(), 900u);
  EXPECT_LE(f.keypoints.size(), 1000u);
  // Spread: count non-empty 40x40 cells of level 0 inside the usable area (19 px border):
  // 15 x 11 = 165 cells. A plain "best 1000 FAST responses" selection on this image clusters on
  // the strongest edges; the grid + round-robin must cover at least 90 % of the cells.
  std::set<int> cells;
  std::set<int> levels;
  for (const auto& kp : f.keypoints) {
    EXPECT_GE(kp.pt.x, 0.f);
    EXPECT_GE(kp.pt.y, 0.f);
    EXPECT_LT(kp.pt.x, 640.f);
    EXPECT_LT(kp.pt.y, 480.f);
    const int cx = static_cast<int>((kp.pt.x - 19) / 40), cy = static_cast<int>((kp.pt.y - 19) / 40);
    if (cx >= 0 && cx < 15 && cy >= 0 && cy < 11) cells.insert(cy * 15 + cx);
    levels.insert(kp.octave);
  }
  EXPECT_GE(cells.size(), static_cast<size_t>(0.9 * 165)) << "non-empty cells " << cells.size();
  EXPECT_GE(levels.size(), 6u) << "keypoints must come from most of the 8 pyramid levels";
}

TEST(OrbExtractor, NoKeypointInsideOrNearTheMask) {
  TrackingOptions options;
  OrbExtractor extractor(options);
  const cv::Mat img = test::texturedImage(4);
  cv::Mat mask(img.size(), CV_8UC1, cv::Scalar(0));
  const cv::Rect dynamic(200, 120, 240, 200);
  mask(dynamic).setTo(255);
  const OrbFeatures f = extractor.extract(img, mask);
  ASSERT_GT(f.keypoints.size(), 500u);
  EXPECT_NEAR(f.masked_fraction, dynamic.area() / (640.0 * 480.0), 1e-9);
  // Relaxed threshold (paper): 20 * (1 - 0.5 * 0.156) = 18.4 -> 18.
  EXPECT_EQ(f.fast_threshold_used, 18);
  for (const auto& kp : f.keypoints) {
    // Euclidean distance to the nearest dynamic pixel [200, 439] x [120, 319] must be at least
    // mask_border_px * scale^level (level-0 px), minus 1 px for rounding to the pixel grid.
    const double border = options.mask_border_px * std::pow(options.scale_factor, kp.octave) - 1.0;
    const double dx = std::max({dynamic.x - kp.pt.x, 0.f, kp.pt.x - (dynamic.br().x - 1)});
    const double dy = std::max({dynamic.y - kp.pt.y, 0.f, kp.pt.y - (dynamic.br().y - 1)});
    EXPECT_GE(std::hypot(dx, dy), border) << "keypoint (" << kp.pt.x << ", " << kp.pt.y << ") level "
                               << kp.octave << " too close to the dynamic area";
  }
}

TEST(OrbExtractor, AllMaskedOrBlackGivesNoKeypoints) {
  OrbExtractor extractor{TrackingOptions()};
  const cv::Mat img = test::texturedImage(5);
  const cv::Mat all_dynamic(img.size(), CV_8UC1, cv::Scalar(255));
  const OrbFeatures masked = extractor.extract(img, all_dynamic);
  EXPECT_TRUE(masked.keypoints.empty());
  EXPECT_DOUBLE_EQ(masked.masked_fraction, 1.0);
  const OrbFeatures black = extractor.extract(cv::Mat(img.size(), CV_8UC1, cv::Scalar(0)), cv::Mat());
  EXPECT_TRUE(black.keypoints.empty());
}

TEST(OrbExtractor, RejectsWrongTypes) {
  OrbExtractor extractor{TrackingOptions()};
  EXPECT_THROW(extractor.extract(cv::Mat(480, 640, CV_8UC3), cv::Mat()), std::invalid_argument);
  EXPECT_THROW(extractor.extract(cv::Mat(480, 640, CV_8UC1), cv::Mat(10, 10, CV_8UC1)),
               std::invalid_argument);
}

}  // namespace
}  // namespace tracking
}  // namespace dypho
