#pragma once
/// \file relaxed_feature_test.h
/// The paper's relaxed feature test ("Feature Extract"): n(|G(p) - G(N(p))| > sigma_dy) > n_f on
/// the 16-pixel FAST ring, with the grey difference normalised by the local grey range, and the
/// adaptive threshold sigma_dy = sigma_0 (1 - k * masked_fraction).

#include <algorithm>
#include <cstdlib>

#include <opencv2/core.hpp>

namespace dypho {
namespace tracking {

/// sigma_dy = sigma_0 (1 - k * masked_fraction), never negative [fraction of the local range].
inline double relaxedThreshold(double sigma0, double k, double masked_fraction) {
  return std::max(0.0, sigma0 * (1.0 - k * masked_fraction));
}

/// Result of the relaxed test at one pixel.
struct RelaxedResponse {
  int count = 0;      ///< ring pixels differing from the centre by more than sigma_dy * range
  int range = 0;      ///< grey range (max - min) over the ring and the centre [grey levels]
  float score = 0.f;  ///< sum of |G(N) - G(p)| over the differing ring pixels [grey levels]
};

/// Offsets of the 16-pixel Bresenham circle of radius 3 (the FAST ring), clockwise from the top.
constexpr int kRingDx[16] = {0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1};
constexpr int kRingDy[16] = {-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3};

/// Evaluates the test at (x, y) of a CV_8UC1 image; the caller keeps (x, y) at least 3 px inside.
inline RelaxedResponse relaxedResponse(const cv::Mat& image, int x, int y, double sigma_dy) {
  const uchar* row = image.ptr<uchar>(y) + x;
  const int step = static_cast<int>(image.step1());
  const int centre = row[0];
  int ring[16];
  int lo = centre, hi = centre;
  for (int i = 0; i < 16; ++i) {
    ring[i] = row[kRingDy[i] * step + kRingDx[i]];
    lo = std::min(lo, ring[i]);
    hi = std::max(hi, ring[i]);
  }
  RelaxedResponse r;
  r.range = hi - lo;
  const double limit = sigma_dy * r.range;
  for (int i = 0; i < 16; ++i) {
    const int d = std::abs(ring[i] - centre);
    if (d > limit) {
      ++r.count;
      r.score += static_cast<float>(d);
    }
  }
  return r;
}

/// True when (x, y) is a relaxed feature: more than `min_count` ring pixels differ and the local
/// range reaches `min_range` (grey levels; keeps sensor noise on flat areas out).
inline bool isRelaxedFeature(const RelaxedResponse& r, int min_count, int min_range) {
  return r.range >= min_range && r.count > min_count;
}

}  // namespace tracking
}  // namespace dypho
