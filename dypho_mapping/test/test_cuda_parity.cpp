/// CUDA rasterizer vs the CPU rasterizer (the reference) on random and edge-case scenes: images,
/// gradients of every Gaussian parameter and of the pose. Without a CUDA device (or a build
/// without CUDA) every test skips itself, and ctest reports "skipped", never "passed".
/// No OpenCV here: this file also builds in the standalone mapping build (standalone/).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/cuda_rasterizer.h"
#include "dypho/mapping/rasterizer.h"
#include "gaussian_params_storage.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

using Scene = GaussianParamsStorage<float>;

#define DYPHO_REQUIRE_CUDA_DEVICE()                                                  \
  do {                                                                               \
    std::string reason;                                                              \
    if (cudaDeviceCount(&reason) <= 0) GTEST_SKIP() << "no CUDA device: " << reason; \
  } while (0)

/// A 150x110 camera (partial tiles on both edges), focal 120 px, looking down +z from (tx, ty, tz).
gs::PinholeView<float> view(float tx = 0.05f, float ty = -0.03f, float tz = 0.1f) {
  gs::PinholeView<float> v{};
  v.width = 150;
  v.height = 110;
  v.fx = v.fy = 120.f;
  v.cx = 74.5f;
  v.cy = 54.5f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) v.R_cw[i][j] = i == j ? 1.f : 0.f;
  // p_c = p_w - centre.
  v.center_w[0] = tx;
  v.center_w[1] = ty;
  v.center_w[2] = tz;
  for (int i = 0; i < 3; ++i) v.t_cw[i] = -v.center_w[i];
  return v;
}

void add(Scene& s, float x, float y, float z, float log_scale0, float log_scale1, float log_scale2, const float q[4],
         float opacity_logit, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  s.pos.insert(s.pos.end(), {x, y, z});
  s.scale.insert(s.scale.end(), {log_scale0, log_scale1, log_scale2});
  s.rot.insert(s.rot.end(), {q[0], q[1], q[2], q[3]});
  s.opa.push_back(opacity_logit);
  const int K3 = 3 * (s.sh_degree + 1) * (s.sh_degree + 1);
  for (int k = 0; k < K3; ++k) s.sh.push_back(k < 3 ? 0.8f * u(rng) : 0.1f * u(rng));
  ++s.n;
}

/// `n` Gaussians 2-4 m in front of the camera, sizes from a few pixels to a third of the image.
Scene randomScene(int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  Scene s;
  for (int i = 0; i < n; ++i) {
    const float base = std::log(0.01f + 0.2f * (0.5f + 0.5f * u(rng)));
    const float q[4] = {1.f, 0.6f * u(rng), 0.6f * u(rng), 0.6f * u(rng)};
    add(s, 1.6f * u(rng), 1.2f * u(rng), 3.f + u(rng), base, base + 0.5f * u(rng), base - 1.f, q, 3.f * u(rng), rng);
  }
  return s;
}

/// The edge cases, each mixed into a random background of 300 Gaussians so images are covered.
Scene edgeScene(const std::string& kind, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  Scene s = kind == "empty" ? Scene() : randomScene(300, rng);
  const float unit[4] = {1.f, 0.f, 0.f, 0.f};
  if (kind == "tiny") {  // sub-pixel: the low-pass filter dominates the footprint
    for (int i = 0; i < 500; ++i) add(s, 1.5f * u(rng), 1.1f * u(rng), 2.f + u(rng), -9.f, -9.5f, -8.f, unit, 4.f, rng);
  } else if (kind == "huge") {  // metres wide, close: each covers the whole image
    for (int i = 0; i < 20; ++i) {
      const float q[4] = {1.f, u(rng), u(rng), u(rng)};
      add(s, 0.3f * u(rng), 0.3f * u(rng), 0.5f + 0.3f * u(rng), 1.f, 0.5f, 0.8f, q, -1.f + u(rng), rng);
    }
  } else if (kind == "behind") {  // behind the camera, at and around the near plane
    for (int i = 0; i < 300; ++i) {
      const float z = i % 3 == 0 ? -2.f * (1.f + u(rng)) : (i % 3 == 1 ? 0.1f + 0.06f * u(rng) : 0.05f * u(rng));
      add(s, u(rng), u(rng), z + 0.1f, std::log(0.05f), std::log(0.05f), std::log(0.05f), unit, 2.f, rng);
    }
  } else if (kind == "degenerate") {  // flat, needle-like, zero and unnormalised quaternions
    for (int i = 0; i < 200; ++i) {
      const float q_zero[4] = {0.f, 0.f, 0.f, 0.f};
      const float q_big[4] = {40.f * u(rng), 30.f, -20.f, 10.f * u(rng)};
      const float* q = i % 4 == 0 ? q_zero : q_big;
      const float flat = i % 2 == 0 ? -30.f : std::log(0.1f);
      add(s, 1.5f * u(rng), 1.1f * u(rng), 2.5f + u(rng), flat, std::log(0.1f), -30.f, q, 2.f, rng);
    }
  } else if (kind == "crowded_tile") {  // thousands of Gaussians inside one 16x16 tile
    for (int i = 0; i < 3000; ++i) {
      // Pixel (40..56, 40..56) at depth z: x = (u - cx) z / f.
      const float z = 2.f + 1.5f * (0.5f + 0.5f * u(rng));
      const float px = 48.f + 7.f * u(rng), py = 48.f + 7.f * u(rng);
      add(s, (px - 74.5f) * z / 120.f + 0.05f, (py - 54.5f) * z / 120.f - 0.03f, z + 0.1f, std::log(0.004f),
          std::log(0.003f), std::log(0.002f), unit, 1.f + u(rng), rng);
    }
  }
  return s;
}

RasterSettings settings(bool thresholds) {
  RasterSettings s;
  if (!thresholds) {  // smooth: no cut-off, alpha threshold or early stop (no decision can flip)
    s.radius_sigma = 1e3;
    s.min_alpha = 0.0;
    s.min_transmittance = 0.0;
  }
  return s;
}

struct Pass {
  RenderResult<float> image;
  GaussianGrads<float> grads;
  std::size_t visible = 0, entries = 0;
};

/// Forward, then backward of a fixed random per-pixel loss gradient.
template <typename Raster>
Pass run(Raster& r, const Scene& scene, const gs::PinholeView<float>& v, std::mt19937::result_type seed) {
  Pass p;
  r.forward(scene.view(), v, p.image);
  const std::size_t npix = static_cast<std::size_t>(v.width) * v.height;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<float> gc(3 * npix), gd(npix), ga(npix);
  for (float& x : gc) x = u(rng);
  for (float& x : gd) x = u(rng);
  for (float& x : ga) x = u(rng);
  r.backward(PixelGrads<float>{gc.data(), gd.data(), ga.data()}, p.grads);
  p.visible = r.numVisible();
  p.entries = r.numTileEntries();
  return p;
}

/// Pixels whose difference exceeds `tol`, and the largest difference.
std::pair<std::size_t, float> countAbove(const std::vector<float>& a, const std::vector<float>& b, float tol) {
  std::size_t n = 0;
  float worst = 0.f;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const float d = std::abs(a[i] - b[i]);
    if (!(d <= tol)) ++n;
    worst = std::max(worst, d);
  }
  return {n, worst};
}

/// Worst |a - b| / max(|a|, 1e-2 * largest |a| of the block): 1e-3 means every value agrees to
/// 0.1 % of itself, values that cancel to near zero to 0.1 % of 1 % of the block's scale.
float relativeError(const std::vector<float>& cpu, const std::vector<float>& gpu) {
  float scale = 0.f;
  for (float v : cpu) scale = std::max(scale, std::abs(v));
  if (scale == 0.f) return cpu == gpu ? 0.f : 1e30f;
  float worst = 0.f;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const float den = std::max(std::abs(cpu[i]), 1e-2f * scale);
    worst = std::max(worst, std::abs(cpu[i] - gpu[i]) / den);
  }
  return worst;
}

/// Compares the CUDA rasterizer with the CPU one on `scene`.
/// Smooth settings: images within 1e-4 absolute (depth within 1e-4 per metre of depth range, 4e-4),
/// every gradient block within 1e-3 relative (relativeError), the pose gradient within 1e-3 of
/// max(1, |value|).
/// Default thresholds: a rounding difference (FMA contraction, libdevice vs glibc exp/sqrt) can
/// flip one pixel's alpha >= 1/255 or early-stop decision, moving that pixel by one Gaussian's
/// contribution at the threshold (<= 6e-3); at most 0.5 % of the pixels may do so, all others
/// keep 1e-4. Gradients are not compared there (a flipped pixel changes them discontinuously).
void compare(const std::string& name, const Scene& scene, bool thresholds) {
  SCOPED_TRACE(name + (thresholds ? " (default thresholds)" : " (smooth)"));
  const gs::PinholeView<float> v = view();
  ThreadPool pool(2);
  Rasterizer<float> cpu_raster(&pool, settings(thresholds));
  CudaRasterizer gpu_raster(settings(thresholds));
  const Pass cpu = run(cpu_raster, scene, v, 11);
  const Pass gpu = run(gpu_raster, scene, v, 11);
  EXPECT_EQ(cpu.visible, gpu.visible);
  EXPECT_EQ(cpu.entries, gpu.entries);
  const std::size_t npix = static_cast<std::size_t>(v.width) * v.height;
  ASSERT_EQ(gpu.image.color.size(), 3 * npix);
  ASSERT_EQ(gpu.image.depth.size(), npix);
  ASSERT_EQ(gpu.image.alpha.size(), npix);
  const auto c = countAbove(cpu.image.color, gpu.image.color, 1e-4f);
  const auto a = countAbove(cpu.image.alpha, gpu.image.alpha, 1e-4f);
  const auto d = countAbove(cpu.image.depth, gpu.image.depth, 4e-4f);
  std::printf(
      "[ report ] %s %s: %zu Gaussians, %zu visible, %zu tile entries; max diff colour %.2e alpha %.2e depth %.2e\n",
      name.c_str(), thresholds ? "thresholds" : "smooth", static_cast<std::size_t>(scene.n), cpu.visible, cpu.entries,
      c.second, a.second, d.second);
  if (!thresholds) {
    EXPECT_EQ(c.first, 0u) << "max " << c.second;
    EXPECT_EQ(a.first, 0u) << "max " << a.second;
    EXPECT_EQ(d.first, 0u) << "max " << d.second;
    EXPECT_LE(relativeError(cpu.grads.position, gpu.grads.position), 1e-3f);
    EXPECT_LE(relativeError(cpu.grads.log_scale, gpu.grads.log_scale), 1e-3f);
    EXPECT_LE(relativeError(cpu.grads.rotation, gpu.grads.rotation), 1e-3f);
    EXPECT_LE(relativeError(cpu.grads.opacity_logit, gpu.grads.opacity_logit), 1e-3f);
    EXPECT_LE(relativeError(cpu.grads.sh, gpu.grads.sh), 1e-3f);
    EXPECT_LE(relativeError(cpu.grads.mean2d_norm, gpu.grads.mean2d_norm), 1e-3f);
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(cpu.grads.pose[k], gpu.grads.pose[k], 1e-3f * std::max(1.f, std::abs(cpu.grads.pose[k])));
    }
  } else {
    const std::size_t flips = npix / 200;
    EXPECT_LE(c.first, 3 * flips);
    EXPECT_LE(a.first, flips);
    EXPECT_LE(d.first, flips);
    EXPECT_LE(c.second, 6e-3f);
    EXPECT_LE(a.second, 6e-3f);
    EXPECT_LE(d.second, 4.f * 6e-3f);
  }
}

TEST(CudaParity, RandomScenes) {
  DYPHO_REQUIRE_CUDA_DEVICE();
  for (int seed = 1; seed <= 3; ++seed) {
    std::mt19937 rng(seed);
    const Scene s = randomScene(2000, rng);
    compare("random seed " + std::to_string(seed), s, false);
    compare("random seed " + std::to_string(seed), s, true);
  }
}

TEST(CudaParity, EdgeCaseScenes) {
  DYPHO_REQUIRE_CUDA_DEVICE();
  for (const char* kind : {"tiny", "huge", "behind", "degenerate", "crowded_tile", "empty"}) {
    std::mt19937 rng(5);
    const Scene s = edgeScene(kind, rng);
    compare(kind, s, false);
    compare(kind, s, true);
  }
}

TEST(CudaParity, EmptySceneRendersBackground) {
  DYPHO_REQUIRE_CUDA_DEVICE();
  CudaRasterizer r;
  RenderResult<float> out;
  r.forward(Scene().view(), view(), out);
  ASSERT_EQ(out.alpha.size(), 150u * 110u);
  for (float a : out.alpha) ASSERT_EQ(a, 0.f);
  for (float c : out.color) ASSERT_EQ(c, 0.f);
  EXPECT_EQ(r.numVisible(), 0u);
}

TEST(CudaParity, BadInputIsAClearError) {
  DYPHO_REQUIRE_CUDA_DEVICE();
  CudaRasterizer r;
  RenderResult<float> out;
  gs::PinholeView<float> v = view();
  v.width = 0;
  EXPECT_THROW(r.forward(Scene().view(), v, out), std::invalid_argument);
  GaussianGrads<float> g;
  CudaRasterizer fresh;
  EXPECT_THROW(fresh.backward(PixelGrads<float>{}, g), std::logic_error);
  RasterSettings bad;
  bad.radius_sigma = 0.0;
  EXPECT_THROW(CudaRasterizer{bad}, std::invalid_argument);
}

// Buffers are reused: a second, smaller scene after a larger one renders exactly as a fresh
// rasterizer does (no stale entries from the larger lists).
TEST(CudaParity, ReuseAfterALargerSceneIsExact) {
  DYPHO_REQUIRE_CUDA_DEVICE();
  std::mt19937 rng(3);
  const Scene big = randomScene(4000, rng), small = randomScene(200, rng);
  CudaRasterizer reused, fresh;
  RenderResult<float> a, b;
  reused.forward(big.view(), view(), a);
  reused.forward(small.view(), view(), a);
  fresh.forward(small.view(), view(), b);
  EXPECT_EQ(a.color, b.color);
  EXPECT_EQ(a.depth, b.depth);
  EXPECT_EQ(a.alpha, b.alpha);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
