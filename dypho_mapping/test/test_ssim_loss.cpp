/// SsimLoss: value on identical and constant images, against a direct 2D reference, gradient
/// against central differences, masking, threads.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/mapping/ssim_loss.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

constexpr int kW = 23, kH = 17;

std::vector<double> randomImage(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.05, 0.95);
  std::vector<double> img(3 * static_cast<std::size_t>(w) * h);
  for (double& x : img) x = u(rng);
  return img;
}

/// Static everywhere except a 6x5 rectangle (dynamic).
std::vector<std::uint8_t> maskWithHole(int w, int h) {
  std::vector<std::uint8_t> m(static_cast<std::size_t>(w) * h, 255);
  for (int v = 4; v < 9; ++v)
    for (int u = 10; u < 16; ++u) m[static_cast<std::size_t>(v) * w + u] = 0;
  return m;
}

/// Mean masked SSIM straight from the definition (2D window sums, no separability), double.
double referenceSsim(const std::vector<double>& x_in, const std::vector<double>& y, const std::vector<std::uint8_t>& m,
                     int w, int h, const double* taps) {
  const int R = SsimLoss<double>::kWindow / 2;
  const std::size_t npix = static_cast<std::size_t>(w) * h;
  std::vector<double> x = x_in;
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < npix; ++i)
      if (!m[i]) x[c * npix + i] = y[c * npix + i];
  double sum = 0.0;
  std::size_t n = 0;
  for (int c = 0; c < 3; ++c)
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        if (!m[static_cast<std::size_t>(v) * w + u]) continue;
        double mx = 0, my = 0, exx = 0, eyy = 0, exy = 0;
        for (int dv = -R; dv <= R; ++dv)
          for (int du = -R; du <= R; ++du) {
            const int uu = u + du, vv = v + dv;
            if (uu < 0 || vv < 0 || uu >= w || vv >= h) continue;  // zero padding
            const double k = taps[du + R] * taps[dv + R];
            const double a = x[c * npix + vv * w + uu], b = y[c * npix + vv * w + uu];
            mx += k * a;
            my += k * b;
            exx += k * a * a;
            eyy += k * b * b;
            exy += k * a * b;
          }
        const double C1 = SsimLoss<double>::kC1, C2 = SsimLoss<double>::kC2;
        const double sxx = exx - mx * mx, syy = eyy - my * my, sxy = exy - mx * my;
        sum += (2 * mx * my + C1) * (2 * sxy + C2) / ((mx * mx + my * my + C1) * (sxx + syy + C2));
        ++n;
      }
  return sum / n;
}

TEST(SsimLoss, WindowIsANormalisedGaussian) {
  SsimLoss<double> ssim(nullptr);
  double sum = 0.0;
  for (int k = 0; k < SsimLoss<double>::kWindow; ++k) sum += ssim.window()[k];
  EXPECT_NEAR(sum, 1.0, 1e-12);
  // Ratio of neighbouring taps of a Gaussian with sigma 1.5: exp(-(2k+1) / (2 * 1.5^2)).
  EXPECT_NEAR(ssim.window()[6] / ssim.window()[5], std::exp(-1.0 / 4.5), 1e-12);
}

TEST(SsimLoss, IdenticalImagesGiveOneAndZeroGradient) {
  const std::vector<double> x = randomImage(kW, kH, 1);
  const std::vector<std::uint8_t> m = maskWithHole(kW, kH);
  SsimLoss<double> ssim(nullptr);
  std::vector<double> grad(x.size(), 0.0);
  EXPECT_NEAR(ssim.compute(x.data(), x.data(), m.data(), kW, kW, kH, 1.0, grad.data()), 1.0, 1e-12);
  for (double g : grad) ASSERT_NEAR(g, 0.0, 1e-12);  // SSIM = 1 is the maximum: stationary
}

TEST(SsimLoss, ConstantImagesHaveTheClosedFormValue) {
  // x = a, y = b everywhere: away from the border (>= 5 px) the windows see constants, so
  // sigma = 0 and SSIM = (2ab + C1) / (a^2 + b^2 + C1).
  const int w = 31, h = 21;
  const double a = 0.2, b = 0.6;
  std::vector<double> x(3 * w * h, a), y(3 * w * h, b), map(3 * w * h, 0.0);
  SsimLoss<double> ssim(nullptr);
  ssim.compute(x.data(), y.data(), nullptr, 0, w, h, 0.0, nullptr, map.data());
  const double expected = (2 * a * b + SsimLoss<double>::kC1) / (a * a + b * b + SsimLoss<double>::kC1);
  for (int c = 0; c < 3; ++c)
    for (int v = 5; v < h - 5; ++v)
      for (int u = 5; u < w - 5; ++u) ASSERT_NEAR(map[c * w * h + v * w + u], expected, 1e-9) << u << "," << v;
  EXPECT_NEAR(expected, 0.6, 0.01);  // 0.24 / 0.4 (sanity of the formula itself)
}

TEST(SsimLoss, MatchesTheDirect2DDefinitionWithAMask) {
  const std::vector<double> x = randomImage(kW, kH, 2), y = randomImage(kW, kH, 3);
  const std::vector<std::uint8_t> m = maskWithHole(kW, kH);
  SsimLoss<double> ssim(nullptr);
  const double value = ssim.compute(x.data(), y.data(), m.data(), kW, kW, kH, 0.0, nullptr);
  // Same sums in another order: agreement to rounding (1e-12 on values of order 1).
  EXPECT_NEAR(value, referenceSsim(x, y, m, kW, kH, ssim.window()), 1e-12);
  EXPECT_LT(value, 0.5);  // unrelated random images are dissimilar
}

TEST(SsimLoss, GradientMatchesCentralDifferences) {
  std::vector<double> x = randomImage(kW, kH, 4);
  const std::vector<double> y = randomImage(kW, kH, 5);
  // Make x resemble y a little so the gradient is not dominated by one term.
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 0.5 * x[i] + 0.5 * y[i];
  const std::vector<std::uint8_t> m = maskWithHole(kW, kH);
  SsimLoss<double> ssim(nullptr);
  const double weight = 2.0;
  std::vector<double> grad(x.size(), 0.0);
  ssim.compute(x.data(), y.data(), m.data(), kW, kW, kH, weight, grad.data());
  auto loss = [&](const std::vector<double>& xx) {
    return weight * (1.0 - ssim.compute(xx.data(), y.data(), m.data(), kW, kW, kH, 0.0, nullptr));
  };
  // Central differences with h = 1e-6 in double: truncation error ~ h^2 |L'''| ~ 1e-12 and
  // rounding ~ 1e-16 |L| / h ~ 1e-10, against gradients of order 1/(3 * 391 pixels) ~ 1e-3: a
  // relative error bound of 1e-5 of the largest gradient leaves two orders of margin and still
  // catches any wrong term (those are off by O(1) relative).
  const double h = 1e-6;
  double max_grad = 0.0, max_err = 0.0;
  const std::size_t npix = static_cast<std::size_t>(kW) * kH;
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::vector<double> xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    const double numeric = (loss(xp) - loss(xm)) / (2 * h);
    max_grad = std::max(max_grad, std::abs(numeric));
    max_err = std::max(max_err, std::abs(numeric - grad[i]));
    if (!m[i % npix]) {
      ASSERT_EQ(grad[i], 0.0) << "dynamic pixel " << i << " has a gradient";
    }
  }
  EXPECT_GT(max_grad, 1e-4);
  EXPECT_LE(max_err, 1e-5 * max_grad) << "max abs error " << max_err << ", max gradient " << max_grad;
}

TEST(SsimLoss, FloatAndThreadsAgreeWithSingleThreadedDouble) {
  const int w = 70, h = 45;  // several rows per thread, borders on every side
  const std::vector<double> x = randomImage(w, h, 6), y = randomImage(w, h, 7);
  const std::vector<std::uint8_t> m(static_cast<std::size_t>(w) * h, 255);
  SsimLoss<double> ref(nullptr);
  std::vector<double> g_ref(x.size(), 0.0);
  const double v_ref = ref.compute(x.data(), y.data(), m.data(), w, w, h, 1.0, g_ref.data());
  ThreadPool pool(3);
  SsimLoss<double> threaded(&pool);
  std::vector<double> g_thr(x.size(), 0.0);
  EXPECT_EQ(threaded.compute(x.data(), y.data(), m.data(), w, w, h, 1.0, g_thr.data()), v_ref);  // fixed-order sums
  EXPECT_EQ(g_thr, g_ref);
  std::vector<float> xf(x.begin(), x.end()), yf(y.begin(), y.end()), gf(x.size(), 0.f);
  SsimLoss<float> single(&pool);
  // float: ~1e-7 relative rounding over ~300 accumulated terms: 1e-5 relative is ample.
  EXPECT_NEAR(single.compute(xf.data(), yf.data(), m.data(), w, w, h, 1.f, gf.data()), v_ref, 1e-5);
  double max_g = 0.0, max_err = 0.0;
  for (std::size_t i = 0; i < gf.size(); ++i) {
    max_g = std::max(max_g, std::abs(g_ref[i]));
    max_err = std::max(max_err, std::abs(gf[i] - g_ref[i]));
  }
  EXPECT_LE(max_err, 1e-4 * max_g);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
