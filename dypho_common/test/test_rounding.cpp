/// roundHalfAway against std::lround.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/rounding.h"

namespace DYPHO_UNITY_ID {

// roundHalfAway gives std::lround's integer: halves away from zero, negatives, the floats at
// 2^22-2^24 whose fraction is 0 or a half, and random values of image coordinates.
TEST(Rounding, FloatMatchesLround) {
  std::vector<float> values = {0.f,  0.5f,   -0.5f,  1.5f,      -1.5f,      2.5f,       0.49999997f, -0.49999997f,
                               -0.f, 319.5f, 639.5f, -1.00001f, 4194304.5f, 8388607.5f, 16777216.f,  -4194304.5f};
  cv::RNG rng(3);
  for (int i = 0; i < 100000; ++i) values.push_back(rng.uniform(-2000.f, 2000.f));
  for (int i = 0; i < 2000; ++i) values.push_back(static_cast<float>(rng.uniform(-4000, 4000)) + 0.5f);
  for (const float v : values) ASSERT_EQ(dypho::roundHalfAway(v), std::lround(v)) << v;
}

// The same for doubles: the one below a half, halves, and large values whose fraction is exact.
TEST(Rounding, DoubleMatchesLround) {
  std::vector<double> values = {
      0.0,   0.5,   -0.5,       1.5,          -1.5,          2.5,    0.49999999999999994, -0.0,
      319.5, 639.5, -1.0000001, 1073741823.5, -1073741823.5, 2.5e-9, 159.49999999999997};
  cv::RNG rng(5);
  for (int i = 0; i < 100000; ++i) values.push_back(rng.uniform(-2000.0, 2000.0));
  for (int i = 0; i < 2000; ++i) values.push_back(rng.uniform(-4000, 4000) + 0.5);
  for (const double v : values) ASSERT_EQ(dypho::roundHalfAway(v), std::lround(v)) << v;
}

}  // namespace DYPHO_UNITY_ID
