/// The CUDA path's kernel bodies (src/cuda/kernel_bodies.h) run on the CPU by the GPU emulator
/// (gpu_emulator.h): the whole GPU pipeline except the hardware parts (atomics, warp sums,
/// lockstep) against the CPU rasterizer, and the training bodies' rules. Runs on every machine,
/// GPU or not. No OpenCV (also in the standalone build); test_training_math.cpp compares the
/// emulated device training with GaussianTrainer itself.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/mapping/rasterizer.h"
#include "dypho/mapping/ssim_loss.h"
#include "gaussian_params_storage.h"
#include "gpu_emulator.h"
#include "kernel_bodies.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

using Scene = GaussianParamsStorage<float>;
namespace body = cuda_body;
using gpu_emulator::emulateDensify;
using gpu_emulator::EmulatedGpuRasterizer;
using gpu_emulator::HostState;

gs::PinholeView<float> view() {
  gs::PinholeView<float> v{};
  v.width = 150;  // partial tiles on both edges
  v.height = 110;
  v.fx = v.fy = 120.f;
  v.cx = 74.5f;
  v.cy = 54.5f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) v.R_cw[i][j] = i == j ? 1.f : 0.f;
  v.center_w[0] = 0.05f;
  v.center_w[1] = -0.03f;
  v.center_w[2] = 0.1f;
  for (int i = 0; i < 3; ++i) v.t_cw[i] = -v.center_w[i];
  return v;
}

/// Random Gaussians 2-4 m ahead, plus a few behind the camera, degenerate and crowded in one tile.
Scene scene(int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  Scene s;
  const int K3 = 3 * (s.sh_degree + 1) * (s.sh_degree + 1);
  auto add = [&](float x, float y, float z, float l0, float l1, float l2, float qw, float qx, float o) {
    s.pos.insert(s.pos.end(), {x, y, z});
    s.scale.insert(s.scale.end(), {l0, l1, l2});
    s.rot.insert(s.rot.end(), {qw, qx, 0.3f * u(rng), 0.3f * u(rng)});
    s.opa.push_back(o);
    for (int k = 0; k < K3; ++k) s.sh.push_back(k < 3 ? 0.8f * u(rng) : 0.1f * u(rng));
    ++s.n;
  };
  for (int i = 0; i < n; ++i) {
    const float base = std::log(0.01f + 0.2f * (0.5f + 0.5f * u(rng)));
    add(1.6f * u(rng), 1.2f * u(rng), 3.f + u(rng), base, base + 0.5f * u(rng), base - 1.f, 1.f, 0.6f * u(rng),
        3.f * u(rng));
  }
  for (int i = 0; i < 50; ++i) add(u(rng), u(rng), -1.f + u(rng), -3.f, -3.f, -3.f, 1.f, 0.f, 2.f);  // behind
  for (int i = 0; i < 50; ++i) add(u(rng), u(rng), 2.f, -30.f, -2.f, -30.f, 0.f, 0.f, 2.f);          // degenerate
  for (int i = 0; i < 400; ++i) {                                                                    // one tile
    const float z = 2.5f + u(rng);
    add((40.f + 6.f * u(rng) - 74.5f) * z / 120.f + 0.05f, (40.f + 6.f * u(rng) - 54.5f) * z / 120.f - 0.03f, z + 0.1f,
        -5.5f, -5.7f, -6.f, 1.f, 0.f, u(rng));
  }
  return s;
}

float maxAbsDiff(const std::vector<float>& a, const std::vector<float>& b) {
  float m = a.size() == b.size() ? 0.f : 1e30f;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

/// Worst |a - b| / max(|a|, 1e-2 * largest |a| of the block) (as in the GPU parity test).
float relativeError(const std::vector<float>& cpu, const std::vector<float>& other) {
  if (cpu.size() != other.size()) return 1e30f;
  float scale = 0.f;
  for (float v : cpu) scale = std::max(scale, std::abs(v));
  if (scale == 0.f) return cpu == other ? 0.f : 1e30f;
  float worst = 0.f;
  for (std::size_t i = 0; i < cpu.size(); ++i)
    worst = std::max(worst, std::abs(cpu[i] - other[i]) / std::max(std::abs(cpu[i]), 1e-2f * scale));
  return worst;
}

// The same per-pixel operations in the same order as the CPU's generic tile kernels (both compiled
// here without FMA), so images agree to 1e-6 and every threshold decision is the same (same
// visible count and tile entries). Gradients: only the order of the additions differs (per pixel
// here, per SIMD lane and thread there): 1e-4 relative.
void compareWithCpu(bool thresholds) {
  RasterSettings s;
  s.isa = RasterIsa::kGeneric;
  if (!thresholds) {
    s.radius_sigma = 1e3;
    s.min_alpha = 0.0;
    s.min_transmittance = 0.0;
  }
  std::mt19937 rng(9);
  const Scene sc = scene(800, rng);
  const gs::PinholeView<float> v = view();
  ThreadPool pool(2);
  Rasterizer<float> cpu(&pool, s);
  EmulatedGpuRasterizer gpu(s);
  RenderResult<float> a, b;
  cpu.forward(sc.view(), v, a);
  gpu.forward(sc.view(), v, b);
  EXPECT_EQ(cpu.numVisible(), gpu.numVisible());
  EXPECT_EQ(cpu.numTileEntries(), gpu.numTileEntries());
  std::size_t covered = 0;
  for (float x : a.alpha) covered += x > 0.5f;
  ASSERT_GT(covered, a.alpha.size() / 2);  // the scene covers the image, or the test says nothing
  EXPECT_LE(maxAbsDiff(a.color, b.color), 1e-6f);
  EXPECT_LE(maxAbsDiff(a.alpha, b.alpha), 1e-6f);
  EXPECT_LE(maxAbsDiff(a.depth, b.depth), 4e-6f);
  const std::size_t npix = a.alpha.size();
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<float> gc(3 * npix), gd(npix), ga(npix);
  for (float& x : gc) x = u(rng);
  for (float& x : gd) x = u(rng);
  for (float& x : ga) x = u(rng);
  const PixelGrads<float> pg{gc.data(), gd.data(), ga.data()};
  GaussianGrads<float> ca, gb;
  cpu.backward(pg, ca);
  gpu.backward(pg, gb);
  EXPECT_LE(relativeError(ca.position, gb.position), 1e-4f);
  EXPECT_LE(relativeError(ca.log_scale, gb.log_scale), 1e-4f);
  EXPECT_LE(relativeError(ca.rotation, gb.rotation), 1e-4f);
  EXPECT_LE(relativeError(ca.opacity_logit, gb.opacity_logit), 1e-4f);
  EXPECT_LE(relativeError(ca.sh, gb.sh), 1e-4f);
  EXPECT_LE(relativeError(ca.mean2d_norm, gb.mean2d_norm), 1e-4f);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(ca.pose[k], gb.pose[k], 1e-4f * std::max(1.f, std::abs(ca.pose[k])));
  std::printf("[ report ] %s: %zu visible, %zu tile entries, image diff %.1e, position gradient rel. error %.1e\n",
              thresholds ? "thresholds" : "smooth", cpu.numVisible(), cpu.numTileEntries(),
              maxAbsDiff(a.color, b.color), relativeError(ca.position, gb.position));
}

TEST(CudaKernelBodies, GpuPipelineOnTheCpuMatchesTheRasterizerSmooth) { compareWithCpu(false); }
TEST(CudaKernelBodies, GpuPipelineOnTheCpuMatchesTheRasterizerWithThresholds) { compareWithCpu(true); }

TEST(CudaKernelBodies, EmptySceneWritesTheBackground) {
  EmulatedGpuRasterizer gpu{RasterSettings()};
  RenderResult<float> out;
  gpu.forward(Scene().view(), view(), out);
  for (float x : out.alpha) ASSERT_EQ(x, 0.f);
  for (float x : out.color) ASSERT_EQ(x, 0.f);
  GaussianGrads<float> g;
  gpu.backward(PixelGrads<float>{}, g);
  EXPECT_TRUE(g.position.empty());
}

// Tile keys order by tile first, then by depth (the IEEE bits of positive floats).
TEST(CudaKernelBodies, TileKeysOrderByTileThenDepth) {
  EXPECT_LT(body::tileKey(3, 5.f), body::tileKey(4, 0.1f));
  EXPECT_LT(body::tileKey(3, 0.5f), body::tileKey(3, 0.50001f));
  EXPECT_LT(body::tileKey(0, 0.06f), body::tileKey(0, 100.f));
}

// The loss body's pixel gradients are the derivative of its sums (away from the kinks of |x|),
// with and without the exposure; masked pixels and pixels without depth get none.
TEST(CudaKernelBodies, LossGradientsAreTheDerivativeOfTheLoss) {
  const int W = 4, H = 3, npix = W * H;
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(0.1f, 0.9f);
  std::vector<float> color(3 * npix), depth(npix), alpha(npix), t_rgb(3 * npix), t_depth(npix);
  std::vector<std::uint8_t> mask(npix, 1);
  for (auto* v : {&color, &t_rgb})
    for (float& x : *v) x = u(rng);
  for (float& x : depth) x = 1.f + u(rng);
  for (float& x : t_depth) x = 1.f + u(rng);
  for (float& x : alpha) x = u(rng);
  mask[5] = 0;
  t_depth[7] = 0.f;
  for (int exposure = 0; exposure < 2; ++exposure) {
    train::LossParams L{};
    L.npix = npix;
    L.wc = 0.1f;
    L.wd = 0.2f;
    L.wa = 0.05f;
    L.exposure = exposure;
    for (int c = 0; c < 3; ++c) {
      L.gain[c] = exposure ? 1.2f : 1.f;
      L.offset[c] = exposure ? 0.05f : 0.f;
    }
    auto loss = [&](const std::vector<float>& c, const std::vector<float>& d, const std::vector<float>& a,
                    std::vector<float>* gc, std::vector<float>* gd, std::vector<float>* ga) {
      std::vector<float> g1(3 * npix), g2(npix), g3(npix);
      float sums[train::kLossSums] = {};
      for (int i = 0; i < npix; ++i)
        train::l1LossPixel(i, L, c.data(), d.data(), a.data(), t_rgb.data(), t_depth.data(), mask.data(), g1.data(),
                           g2.data(), g3.data(), sums);
      if (gc) *gc = g1;
      if (gd) *gd = g2;
      if (ga) *ga = g3;
      // The weights are per-value gradient magnitudes: loss = wc sum|c| + wd sum|d| + wa sum(1 - a).
      return L.wc * sums[0] + L.wd * sums[1] + L.wa * sums[2];
    };
    std::vector<float> gc, gd, ga;
    loss(color, depth, alpha, &gc, &gd, &ga);
    const float h = 1e-3f;
    for (int i = 0; i < npix; ++i) {
      std::vector<float> c2 = color;
      c2[i] += h;
      const float num =
          (loss(c2, depth, alpha, nullptr, nullptr, nullptr) - loss(color, depth, alpha, nullptr, nullptr, nullptr)) /
          h;
      EXPECT_NEAR(gc[i], num, 2e-3f) << "colour pixel " << i << " exposure " << exposure;
      std::vector<float> d2 = depth;
      d2[i] += h;
      const float numd =
          (loss(color, d2, alpha, nullptr, nullptr, nullptr) - loss(color, depth, alpha, nullptr, nullptr, nullptr)) /
          h;
      EXPECT_NEAR(gd[i], numd, 2e-3f) << "depth pixel " << i;
      std::vector<float> a2 = alpha;
      a2[i] += h;
      const float numa =
          (loss(color, depth, a2, nullptr, nullptr, nullptr) - loss(color, depth, alpha, nullptr, nullptr, nullptr)) /
          h;
      EXPECT_NEAR(ga[i], numa, 2e-3f) << "alpha pixel " << i;
    }
    EXPECT_EQ(gc[5], 0.f);  // masked
    EXPECT_EQ(gd[5], 0.f);
    EXPECT_EQ(gd[7], 0.f);  // no depth
    EXPECT_EQ(ga[7], 0.f);
  }
}

// Adam body: the SH block's first three values of a row (DC) take the main step, the rest the
// SH-rest step.
TEST(CudaKernelBodies, AdamUsesTheShRestStepAfterTheDcCoefficients) {
  AdamStepSizes s;
  s.step[4] = 1.f;
  s.step_sh_rest = 0.f;
  s.inv_c2 = 1.f;
  std::vector<float> g(24, 1.f), x(24, 0.f), m(24, 0.f), v(24, 0.f);
  for (std::size_t i = 0; i < 24; ++i) body::adam(i, 12, true, s, 4, g.data(), x.data(), m.data(), v.data());
  for (std::size_t i = 0; i < 24; ++i) {
    if (i % 12 < 3) {
      EXPECT_LT(x[i], 0.f) << i;
    } else {
      EXPECT_EQ(x[i], 0.f) << i;
    }
  }
}

// GaussianTrainer::densifyAndPrune's rules: small and above the gradient threshold -> one exact
// copy; large -> two displaced halves 1.6x smaller and the parent removed when both fit; below the
// threshold or never visible -> nothing; transparent -> removed. Children are appended in parent
// order, and the capacity cuts them where the host loop stops (a split that does not fit keeps
// its parent). New rows start with zero Adam moments, kept rows keep theirs.
TEST(CudaKernelBodies, DensifyAndPruneFollowTheHostRules) {
  HostState st;
  const float small = std::log(0.01f), large = std::log(0.1f);
  st.add(0.f, small, 2.f, 1.f, 10);    // 0: clone
  st.add(1.f, large, 2.f, 1.f, 10);    // 1: split
  st.add(2.f, small, 2.f, 1e-5f, 10);  // 2: below the threshold
  st.add(3.f, small, 2.f, 1.f, 0);     // 3: never visible
  st.add(4.f, small, -10.f, 0.f, 0);   // 4: transparent: pruned
  st.add(5.f, large, 2.f, 1.f, 10);    // 5: split, but no room left
  DensifySettings s;
  s.grad_threshold = 2e-4f;
  s.log_split_scale = std::log(0.02f);
  s.min_opacity_logit = std::log(0.005f / 0.995f);
  s.max_log_scale = std::log(0.3f);
  s.seed = 12345u;
  const HostState before = st;
  const DensifyOutcome o = emulateDensify(st, s, 9);  // room for 3 of the 5 children
  EXPECT_TRUE(o.capacity_hit);
  ASSERT_EQ(o.parents, (std::vector<std::uint32_t>{0, 1, 1}));
  ASSERT_EQ(o.remove, (std::vector<std::uint8_t>{0, 1, 0, 0, 1, 0, 0, 0, 0}));
  ASSERT_EQ(st.n, 7u);  // rows 0, 2, 3, 5, clone of 0, two halves of 1
  const int kept_old[4] = {0, 2, 3, 5};
  for (int r = 0; r < 4; ++r)
    for (int p = 0; p < 5; ++p)
      for (int c = 0; c < HostState::kWidths[p]; ++c) {
        const int w = HostState::kWidths[p];
        EXPECT_EQ(st.params[p][r * w + c], before.params[p][kept_old[r] * w + c]);
        EXPECT_EQ(st.m[p][r * w + c], 0.5f);
        EXPECT_EQ(st.v[p][r * w + c], 0.25f);
      }
  for (int p = 0; p < 5; ++p)  // the clone: an exact copy of Gaussian 0 with zero moments
    for (int c = 0; c < HostState::kWidths[p]; ++c) {
      const int w = HostState::kWidths[p];
      EXPECT_EQ(st.params[p][4 * w + c], before.params[p][c]);
      EXPECT_EQ(st.m[p][4 * w + c], 0.f);
      EXPECT_EQ(st.v[p][4 * w + c], 0.f);
    }
  for (int half = 5; half <= 6; ++half) {  // the halves of Gaussian 1
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(st.params[1][half * 3 + c], before.params[1][3 + c] - std::log(1.6f), 1e-6f);
    float moved = 0.f;
    for (int c = 0; c < 3; ++c) moved += std::abs(st.params[0][half * 3 + c] - before.params[0][3 + c]);
    EXPECT_GT(moved, 0.f);
    EXPECT_LT(moved, 3.f * 5.f * 0.1f);  // within 5 standard deviations (0.1 m) per axis
    EXPECT_EQ(st.params[3][half], before.params[3][1]);
  }
  EXPECT_NE(st.params[0][5 * 3], st.params[0][6 * 3]);  // two different samples
}

// The split offsets' samples are standard normal (mean 0, variance 1) and differ per axis.
TEST(CudaKernelBodies, SplitSamplesAreStandardNormal) {
  double sum = 0.0, sum2 = 0.0, cross = 0.0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double a = train::normalSample(7u, static_cast<std::uint32_t>(i), 0, 0);
    const double b = train::normalSample(7u, static_cast<std::uint32_t>(i), 0, 1);
    sum += a;
    sum2 += a * a;
    cross += a * b;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.03);    // 4 standard errors (1/sqrt(n) = 0.007)
  EXPECT_NEAR(sum2 / n, 1.0, 0.05);   // standard error of the variance sqrt(2/n) = 0.01
  EXPECT_NEAR(cross / n, 0.0, 0.03);  // independent axes
}

// The device SSIM passes (horizontal, vertical with the per-pixel SSIM, adjoint horizontal,
// adjoint vertical with the gradient), run in kernel order, give SsimLoss's value and gradient.
TEST(CudaKernelBodies, SsimPassesMatchSsimLoss) {
  const int W = 37, H = 23;  // odd sizes: windows cut by every border
  const std::size_t npix = static_cast<std::size_t>(W) * H;
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u01(0.f, 1.f);
  std::vector<float> shown(3 * npix), target(3 * npix);
  for (float& x : shown) x = u01(rng);
  for (std::size_t i = 0; i < 3 * npix; ++i) target[i] = 0.7f * shown[i] + 0.3f * u01(rng);
  std::vector<std::uint8_t> mask(npix, 1);
  for (int v = 5; v < 12; ++v)
    for (int u = 10; u < 20; ++u) mask[v * W + u] = 0;  // a person
  std::size_t n_static = 0;
  for (std::uint8_t m : mask) n_static += m;
  const float weight = 0.7f;
  SsimLoss<float> reference(nullptr);
  std::vector<float> grad_ref(3 * npix, 0.f);
  const double mean_ref = reference.compute(shown.data(), target.data(), mask.data(), W, W, H, weight, grad_ref.data());

  const body::SsimImages im{shown.data(), target.data(), mask.data(), W, H};
  const ssim::Taps<float> taps = ssim::windowTaps<float>();
  std::vector<float> h[5], terms[3];
  for (auto& x : h) x.resize(3 * npix);
  for (auto& x : terms) x.resize(3 * npix);
  auto forEach = [&](auto&& fn) {
    for (int c = 0; c < 3; ++c)
      for (int v = 0; v < H; ++v)
        for (int u = 0; u < W; ++u) fn(c, v, u, c * npix + static_cast<std::size_t>(v) * W + u);
  };
  forEach([&](int c, int v, int u, std::size_t i) {  // ssimHorizontalKernel
    float out[5];
    body::ssimHorizontal(im, taps, c, v, u, out);
    for (int j = 0; j < 5; ++j) h[j][i] = out[j];
  });
  double sum = 0.0;
  forEach([&](int c, int v, int u, std::size_t i) {  // ssimVerticalKernel
    float acc[5];
    for (int j = 0; j < 5; ++j) acc[j] = body::verticalAt(h[j].data(), taps, c, v, u, W, H);
    const float m = mask[v * W + u] ? 1.f : 0.f;
    const ssim::PixelSsim<float> px = ssim::pixelSsim(acc[0], acc[1], acc[2], acc[3], acc[4], m);
    terms[0][i] = px.p0;
    terms[1][i] = px.p1;
    terms[2][i] = px.p2;
    sum += m * px.S;
  });
  forEach([&](int c, int v, int u, std::size_t i) {  // ssimAdjointHorizontalKernel
    for (int j = 0; j < 3; ++j) h[j][i] = body::horizontalAt(terms[j].data(), taps, c, v, u, W, H);
  });
  std::vector<float> grad(3 * npix, 0.f);
  const float scale = -weight / static_cast<float>(3 * n_static);
  forEach([&](int c, int v, int u, std::size_t i) {  // ssimGradientKernel
    if (!mask[v * W + u]) return;
    float G[3];
    for (int j = 0; j < 3; ++j) G[j] = body::verticalAt(h[j].data(), taps, c, v, u, W, H);
    float x, y;
    body::ssimXY(im, c, v, u, x, y);
    grad[i] += ssim::ssimGradient(scale, G[0], G[1], G[2], x, y);
  });
  const double mean = sum / (3.0 * n_static);
  EXPECT_NEAR(mean, mean_ref, 1e-6);
  EXPECT_GT(mean_ref, 0.3);  // a real comparison: neither identical images nor noise
  EXPECT_LT(mean_ref, 0.99);
  EXPECT_LE(relativeError(grad_ref, grad), 1e-4f);
}

// With an SSIM term the exposure's chain rule runs after it: the deferred path (L1 without the
// chain, then exposureChain) gives exactly the fused path's gradients and exposure sums.
TEST(CudaKernelBodies, DeferredExposureChainEqualsTheFusedOne) {
  const int npix = 50;
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(0.1f, 0.9f);
  std::vector<float> color(3 * npix), depth(npix), alpha(npix), t_rgb(3 * npix), t_depth(npix);
  std::vector<std::uint8_t> mask(npix, 1);
  for (auto* v : {&color, &t_rgb, &alpha})
    for (float& x : *v) x = u(rng);
  for (float& x : depth) x = 1.f + u(rng);
  for (float& x : t_depth) x = 1.f + u(rng);
  mask[3] = 0;
  train::LossParams L{};
  L.npix = npix;
  L.wc = 0.1f;
  L.wd = 0.2f;
  L.wa = 0.05f;
  L.exposure = 1;
  for (int c = 0; c < 3; ++c) {
    L.gain[c] = 1.1f + 0.1f * c;
    L.offset[c] = 0.02f * c;
  }
  std::vector<float> gc1(3 * npix), gc2(3 * npix), gd(npix), ga(npix), shown(3 * npix);
  float fused[train::kLossSums] = {}, deferred[train::kLossSums] = {};
  for (int i = 0; i < npix; ++i)
    train::l1LossPixel(i, L, color.data(), depth.data(), alpha.data(), t_rgb.data(), t_depth.data(), mask.data(),
                       gc1.data(), gd.data(), ga.data(), fused);
  L.defer_exposure = 1;
  for (int i = 0; i < npix; ++i)
    train::l1LossPixel(i, L, color.data(), depth.data(), alpha.data(), t_rgb.data(), t_depth.data(), mask.data(),
                       gc2.data(), gd.data(), ga.data(), deferred, shown.data());
  for (int i = 0; i < npix; ++i) train::exposureChain(i, L, shown.data(), gc2.data(), deferred);
  for (int k = 0; k < train::kLossSums; ++k)
    EXPECT_NEAR(deferred[k], fused[k], 1e-5f * (1.f + std::abs(fused[k]))) << k;
  for (int i = 0; i < 3 * npix; ++i) EXPECT_FLOAT_EQ(gc2[i], gc1[i]) << i;
  for (int i = 0; i < 3 * npix; ++i) EXPECT_FLOAT_EQ(shown[i], L.gain[i / npix] * color[i] + L.offset[i / npix]);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
