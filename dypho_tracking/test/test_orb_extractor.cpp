#include <algorithm>
#include <array>
#include <iostream>
#include <cmath>
#include <optional>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tracking/orb_extractor.h"
#include "dypho/tracking/relaxed_feature_test.h"
#include "synthetic_scene.h"
#include "../src/core/orb_grid.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

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
    EXPECT_GE(std::hypot(dx, dy), border)
        << "keypoint (" << kp.pt.x << ", " << kp.pt.y << ") level " << kp.octave << " too close to the dynamic area";
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
  EXPECT_THROW(extractor.extract(cv::Mat(480, 640, CV_8UC1), cv::Mat(10, 10, CV_8UC1)), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

/// Image with a FAST-invisible pattern: centre pixel `centre` and the 16 ring pixels set to
/// `ring[i]`, everything else `background`.
cv::Mat ringPattern(int centre, const std::array<int, 16>& ring, int background = 128) {
  cv::Mat img(64, 64, CV_8UC1, cv::Scalar(background));
  img.at<uchar>(32, 32) = static_cast<uchar>(centre);
  for (int i = 0; i < 16; ++i) img.at<uchar>(32 + kRingDy[i], 32 + kRingDx[i]) = static_cast<uchar>(ring[i]);
  return img;
}

TEST(RelaxedFeatureTest, AdaptiveThresholdFollowsThePaper) {
  // sigma_dy = sigma_0 (1 - k * masked_fraction) with the paper's sigma_0 = 0.3, k = 0.9.
  EXPECT_DOUBLE_EQ(relaxedThreshold(0.3, 0.9, 0.0), 0.3);
  EXPECT_NEAR(relaxedThreshold(0.3, 0.9, 0.5), 0.165, 1e-12);
  EXPECT_NEAR(relaxedThreshold(0.3, 0.9, 1.0), 0.03, 1e-12);
  EXPECT_DOUBLE_EQ(relaxedThreshold(0.3, 0.0, 0.7), 0.3);  // k = 0: no adaptation
  EXPECT_GE(relaxedThreshold(0.3, 1.0, 1.0), 0.0);
}

TEST(RelaxedFeatureTest, CountsMixedSignDifferencesThatFastRejects) {
  // Ring alternating 40 grey levels above and below the centre: 16 differing pixels, but no arc of
  // one sign longer than 1, so FAST (which needs 9 contiguous) rejects the centre at any threshold.
  std::array<int, 16> ring{};
  for (int i = 0; i < 16; ++i) ring[static_cast<size_t>(i)] = i % 2 == 0 ? 168 : 88;
  const cv::Mat img = ringPattern(128, ring);
  const RelaxedResponse r = relaxedResponse(img, 32, 32, 0.3);
  EXPECT_EQ(r.count, 16);
  EXPECT_EQ(r.range, 80);
  EXPECT_FLOAT_EQ(r.score, 16 * 40.f);
  EXPECT_TRUE(isRelaxedFeature(r, 12, 20));
  std::vector<cv::KeyPoint> fast;
  cv::FAST(img, fast, 7, true);
  for (const auto& kp : fast) EXPECT_FALSE(kp.pt.x == 32.f && kp.pt.y == 32.f);
  // The local range must reach the floor: the same pattern at +-5 grey levels is noise.
  for (int i = 0; i < 16; ++i) ring[static_cast<size_t>(i)] = i % 2 == 0 ? 133 : 123;
  EXPECT_FALSE(isRelaxedFeature(relaxedResponse(ringPattern(128, ring), 32, 32, 0.3), 12, 20));
}

TEST(RelaxedFeatureTest, ALowerThresholdAdmitsWeakerPoints) {
  // 13 ring pixels 25 above the centre, 3 pixels 100 above: range 100. At sigma_dy = 0.3 only the
  // 3 strong pixels exceed 30 (not a feature); at the masked-frame threshold 0.165 (half the view
  // masked) all 16 exceed 16.5 (a feature). This is how the test keeps the count up under masks.
  std::array<int, 16> ring{};
  for (int i = 0; i < 16; ++i) ring[static_cast<size_t>(i)] = i < 3 ? 200 : 125;
  const cv::Mat img = ringPattern(100, ring);
  const RelaxedResponse strict = relaxedResponse(img, 32, 32, relaxedThreshold(0.3, 0.9, 0.0));
  const RelaxedResponse relaxed = relaxedResponse(img, 32, 32, relaxedThreshold(0.3, 0.9, 0.5));
  EXPECT_EQ(strict.count, 3);
  EXPECT_EQ(relaxed.count, 16);
  EXPECT_FALSE(isRelaxedFeature(strict, 12, 20));
  EXPECT_TRUE(isRelaxedFeature(relaxed, 12, 20));
}

/// Low-contrast texture: Gaussian noise blurred with sigma 1.5 px, grey standard deviation ~8.
cv::Mat lowContrastImage(int seed) {
  cv::RNG rng(static_cast<uint64_t>(seed));
  cv::Mat noise(480, 640, CV_32FC1);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
  cv::Mat img;
  noise.convertTo(img, CV_8UC1, 45.0, 128.0);
  return img;
}

TEST(OrbExtractor, RelaxedFeaturesFillTheBudgetOnMaskedFrames) {
  // FAST at 30 grey levels (both tiers) finds few corners in this texture, so the budget is not
  // filled and the relaxed tier (local range >= 30) has cells to work in.
  TrackingOptions off;
  off.relaxed_features = false;
  off.fast_threshold = 30;
  off.min_fast_threshold = 30;
  TrackingOptions on = off;
  on.relaxed_features = true;
  OrbExtractor extractor_off(off), extractor_on(on);
  const cv::Mat img = lowContrastImage(7);
  // Without a mask the relaxed tier is not used (it is specific to dynamic masking).
  const OrbFeatures plain_off = extractor_off.extract(img, cv::Mat());
  const OrbFeatures plain_on = extractor_on.extract(img, cv::Mat());
  ASSERT_EQ(plain_off.keypoints.size(), plain_on.keypoints.size());
  EXPECT_EQ(plain_on.num_relaxed, 0);

  cv::Mat mask(img.size(), CV_8UC1, cv::Scalar(0));
  const cv::Rect dynamic(0, 0, 320, 480);  // half of the view, as when a person stands close
  mask(dynamic).setTo(255);
  const OrbFeatures masked_off = extractor_off.extract(img, mask);
  const OrbFeatures masked_on = extractor_on.extract(img, mask);
  EXPECT_NEAR(masked_on.relaxed_threshold_used, 0.165, 1e-9);
  EXPECT_EQ(masked_off.num_relaxed, 0);
  EXPECT_GT(masked_on.num_relaxed, 0);
  EXPECT_EQ(masked_on.keypoints.size(), masked_off.keypoints.size() + static_cast<size_t>(masked_on.num_relaxed));
  EXPECT_LE(masked_on.keypoints.size(), static_cast<size_t>(on.num_features));
  ASSERT_EQ(static_cast<int>(masked_on.keypoints.size()), masked_on.descriptors.rows);
  for (const auto& kp : masked_on.keypoints) {
    // Static side only, outside the mask border (scaled by the level, 1 px rounding).
    EXPECT_GE(kp.pt.x, 320.0 + on.mask_border_px * std::pow(on.scale_factor, kp.octave) - 1.0);
  }
  std::cout << "keypoints on the unmasked half: FAST only " << masked_off.keypoints.size() << ", with relaxed features "
            << masked_on.keypoints.size() << " (" << masked_on.num_relaxed << " relaxed)\n";
}

cv::KeyPoint withResponse(float response) { return cv::KeyPoint(0.f, 0.f, 7.f, -1.f, response); }

std::vector<float> responses(const std::vector<cv::KeyPoint>& keypoints) {
  std::vector<float> out;
  for (const cv::KeyPoint& kp : keypoints) out.push_back(kp.response);
  return out;
}

// The grid step alone: every cell's best keypoint comes before any cell's second; the round that
// overflows the budget keeps its best.
TEST(OrbGrid, DistributeOverCellsServesCellsRoundRobin) {
  std::vector<std::vector<cv::KeyPoint>> cells = {{withResponse(1.f), withResponse(5.f), withResponse(0.5f)},
                                                  {withResponse(3.f)},
                                                  {withResponse(2.f), withResponse(4.f)}};
  EXPECT_EQ(responses(distributeOverCells(cells, 4)), (std::vector<float>{5.f, 3.f, 4.f, 2.f}));
  EXPECT_EQ(responses(cells[0]), (std::vector<float>{5.f, 1.f, 0.5f}));  // sorted in place, best first
  EXPECT_EQ(responses(distributeOverCells(cells, 2)), (std::vector<float>{5.f, 4.f}));
  EXPECT_EQ(distributeOverCells(cells, 100).size(), 6u);
  EXPECT_TRUE(distributeOverCells(cells, 0).empty());
}

// A VGA level-0 grid: 15 x 11 cells of about 40 px inside the 19-px border, tiling the usable
// area; a level too small for a patch has none.
TEST(OrbGrid, LevelGridTilesTheUsableArea) {
  const std::optional<LevelGrid> grid = levelGrid(cv::Size(640, 480), OrbExtractor::kEdgePx, 40);
  ASSERT_TRUE(grid.has_value());
  EXPECT_EQ(grid->ncols, 15);
  EXPECT_EQ(grid->nrows, 11);
  const cv::Rect usable(19, 19, 602, 442);
  int covered_px = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(grid->ncols * grid->nrows); ++i) {
    const cv::Rect cell = grid->cellRect(i);
    EXPECT_EQ(cell & usable, cell);
    EXPECT_GE(cell.width, 40);
    covered_px += cell.area();
  }
  EXPECT_GE(covered_px, usable.area());  // cells overlap by under a pixel, never leave a gap
  EXPECT_EQ(grid->cellRect(0), cv::Rect(19, 19, 41, 41));
  EXPECT_FALSE(levelGrid(cv::Size(45, 480), OrbExtractor::kEdgePx, 40).has_value());
}

// The distance to the mask on the dynamic pixels' grown box only: below the reach exactly what
// cv::distanceTransform gives on the whole image (same chamfer arithmetic, so equality is exact),
// at or beyond it at least the reach. Masks: a blob, two far apart (a box spanning the image),
// one touching the border, a single pixel.
TEST(OrbGrid, DistanceToDynamicMatchesTheWholeImageTransformWithinTheReach) {
  const double reach_px = 14.4;  // 4 px border at the coarsest of 8 levels of scale factor 1.2
  std::vector<cv::Mat> masks;
  for (int k = 0; k < 4; ++k) masks.emplace_back(cv::Mat::zeros(480, 640, CV_8UC1));
  cv::circle(masks[0], cv::Point(300, 200), 40, cv::Scalar(255), cv::FILLED);
  cv::rectangle(masks[1], cv::Rect(50, 60, 30, 100), cv::Scalar(255), cv::FILLED);
  cv::rectangle(masks[1], cv::Rect(500, 300, 60, 40), cv::Scalar(255), cv::FILLED);
  cv::rectangle(masks[2], cv::Rect(0, 400, 120, 80), cv::Scalar(255), cv::FILLED);
  masks[3].at<uchar>(240, 320) = 255;
  for (const cv::Mat& mask : masks) {
    cv::Mat is_static, whole;
    cv::compare(mask, 0, is_static, cv::CMP_EQ);
    cv::distanceTransform(is_static, whole, cv::DIST_L2, 3);
    const cv::Mat boxed = distanceToDynamic(mask, reach_px);
    ASSERT_EQ(boxed.size(), mask.size());
    ASSERT_EQ(boxed.type(), CV_32FC1);
    int within = 0, mismatched = 0;
    for (int y = 0; y < mask.rows; ++y) {
      for (int x = 0; x < mask.cols; ++x) {
        const float expected = whole.at<float>(y, x), got = boxed.at<float>(y, x);
        if (expected < reach_px) {
          ++within;
          if (got != expected) ++mismatched;
        } else if (got < reach_px) {
          ++mismatched;
        }
      }
    }
    EXPECT_GT(within, cv::countNonZero(mask));  // the ring around the mask was compared too
    EXPECT_EQ(mismatched, 0);
  }
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
