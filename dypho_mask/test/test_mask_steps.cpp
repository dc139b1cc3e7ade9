// Steps of the mask core tested alone: the internal helpers (mask_internal.h) and the far depth
// of the depth-layer cut (depth_layers.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "../src/core/depth_layers.h"
#include "../src/core/mask_internal.h"

using namespace dypho::mask;

TEST(MaskInternal, ValidDepthIsPositiveAndFinite) {
  EXPECT_TRUE(internal::valid(1.5f));
  EXPECT_FALSE(internal::valid(0.f));
  EXPECT_FALSE(internal::valid(-1.f));
  EXPECT_FALSE(internal::valid(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_FALSE(internal::valid(std::numeric_limits<float>::infinity()));
}

TEST(MaskInternal, MsSinceIsNonNegative) {
  const auto t0 = internal::Clock::now();
  EXPECT_GE(internal::msSince(t0), 0.0);
}

// sortDepths (the radix sort of the depth-layer steps) gives std::sort's order, element for
// element, for depths > 0: short and long vectors (it switches at 256), repeated values, depths
// across the sensor's range and beyond, the smallest positive floats and +inf.
TEST(MaskInternal, SortDepthsMatchesStdSort) {
  cv::RNG rng(7);
  for (const std::size_t n : {0u, 1u, 2u, 255u, 256u, 257u, 5000u, 40000u}) {
    std::vector<float> z(n);
    for (float& v : z) {
      const int kind = rng.uniform(0, 20);
      if (kind == 0) {
        v = std::numeric_limits<float>::infinity();
      } else if (kind == 1) {
        v = std::numeric_limits<float>::denorm_min() * static_cast<float>(rng.uniform(1, 4));
      } else if (kind == 2) {
        v = 1.25f;  // many equal depths
      } else {
        v = rng.uniform(0.05f, 60.f);
      }
    }
    std::vector<float> want = z;
    std::sort(want.begin(), want.end());
    internal::sortDepths(z);
    ASSERT_EQ(z.size(), want.size());
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(z[i], want[i]) << "n " << n << " index " << i;
  }
}

TEST(DepthLayers, RegionFarDepthIsThe95thPercentileOfValidDepths) {
  // Region 1: 20 pixels at 1..20 m plus holes (0, NaN) that do not count; region 2: no depth.
  cv::Mat regions = cv::Mat::zeros(4, 10, CV_32S);
  cv::Mat depth(4, 10, CV_32FC1, cv::Scalar(7.f));  // label 0 (outside every region) is ignored
  for (int i = 0; i < 20; ++i) {
    regions.at<int>(i / 10, i % 10) = 1;
    depth.at<float>(i / 10, i % 10) = static_cast<float>(20 - i);  // unsorted on purpose
  }
  regions.at<int>(2, 0) = 1;
  depth.at<float>(2, 0) = 0.f;
  regions.at<int>(2, 1) = 1;
  depth.at<float>(2, 1) = std::numeric_limits<float>::quiet_NaN();
  regions(cv::Rect(0, 3, 4, 1)).setTo(2);
  depth(cv::Rect(0, 3, 4, 1)).setTo(0.f);

  const std::vector<float> far = internal::regionFarDepths(depth, regions, 3);
  ASSERT_EQ(far.size(), 3u);
  EXPECT_EQ(far[0], 0.f);
  EXPECT_EQ(far[1], 19.f);  // sorted 1..20, index floor(0.95 * 19) = 18
  EXPECT_EQ(far[2], 0.f);   // no valid depth
}
