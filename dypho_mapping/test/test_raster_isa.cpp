/// The two builds of the CPU tile kernels (generic and AVX2+FMA, chosen at run time) render the
/// same images and the same gradients, and the choice follows the CPU.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/common/camera.h"
#include "dypho/mapping/rasterizer.h"
#include "gaussian_params_storage.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

using FloatScene = GaussianParamsStorage<float>;

/// `n` Gaussians 2-4 m in front of the camera, some crossing the image border, sizes from a few
/// pixels to a third of the image, opacities from nearly transparent to nearly opaque.
FloatScene randomScene(int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  FloatScene s;
  s.n = n;
  const int K3 = 3 * (s.sh_degree + 1) * (s.sh_degree + 1);
  for (int i = 0; i < n; ++i) {
    s.pos.insert(s.pos.end(), {1.6f * u(rng), 1.2f * u(rng), 3.f + u(rng)});
    const float base = std::log(0.01f + 0.2f * (0.5f + 0.5f * u(rng)));
    s.scale.insert(s.scale.end(), {base, base + 0.5f * u(rng), base - 1.f});
    s.rot.insert(s.rot.end(), {1.f, 0.6f * u(rng), 0.6f * u(rng), 0.6f * u(rng)});
    s.opa.push_back(3.f * u(rng));
    for (int k = 0; k < K3; ++k) s.sh.push_back(k < 3 ? 0.8f * u(rng) : 0.1f * u(rng));
  }
  return s;
}

CameraIntrinsics camera() {
  CameraIntrinsics cam;
  cam.width = 150;  // partial tiles on both edges
  cam.height = 110;
  cam.fx = cam.fy = 120.0;
  cam.cx = 74.5;
  cam.cy = 54.5;
  return cam;
}

RasterSettings settingsWith(RasterIsa isa, bool thresholds) {
  RasterSettings s;
  s.isa = isa;
  if (!thresholds) {  // smooth: no cut-off, alpha threshold or early stop (no decision can flip)
    s.radius_sigma = 1e3;
    s.min_alpha = 0.0;
    s.min_transmittance = 0.0;
  }
  return s;
}

float maxAbsDiff(const std::vector<float>& a, const std::vector<float>& b) {
  float m = 0.f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

/// Largest difference relative to the largest magnitude of the block.
float maxRelDiff(const std::vector<float>& a, const std::vector<float>& b) {
  float scale = 1e-20f;
  for (float v : a) scale = std::max(scale, std::abs(v));
  return maxAbsDiff(a, b) / scale;
}

TEST(RasterIsa, AutoResolvesToWhatThisCpuRuns) {
  ThreadPool pool(1);
  const Rasterizer<float> automatic(&pool, settingsWith(RasterIsa::kAuto, true));
  EXPECT_EQ(automatic.isa(), rasterAvx2Available() ? RasterIsa::kAvx2 : RasterIsa::kGeneric);
  const Rasterizer<float> generic(&pool, settingsWith(RasterIsa::kGeneric, true));
  EXPECT_EQ(generic.isa(), RasterIsa::kGeneric);
  // Asking for AVX2 works exactly when the CPU has it; otherwise it is a clear error, not SIGILL.
  if (rasterAvx2Available()) {
    EXPECT_EQ(Rasterizer<float>(&pool, settingsWith(RasterIsa::kAvx2, true)).isa(), RasterIsa::kAvx2);
  } else {
    EXPECT_THROW(Rasterizer<float>(&pool, settingsWith(RasterIsa::kAvx2, true)), std::invalid_argument);
  }
  EXPECT_STREQ(rasterIsaName(RasterIsa::kAvx2), "avx2");
  EXPECT_STREQ(rasterIsaName(RasterIsa::kGeneric), "generic");
}

struct Pass {
  RenderResult<float> image;
  GaussianGrads<float> grads;
};

Pass renderAndBack(RasterIsa isa, bool thresholds, const FloatScene& scene, const gs::PinholeView<float>& view,
                   const std::vector<float>& w_color, const std::vector<float>& w_depth) {
  ThreadPool pool(2);
  Rasterizer<float> r(&pool, settingsWith(isa, thresholds));
  Pass p;
  r.forward(scene.view(), view, p.image);
  PixelGrads<float> g;
  g.color = w_color.data();
  g.depth = w_depth.data();
  g.alpha = w_depth.data();
  r.backward(g, p.grads);
  return p;
}

void compareIsas(bool thresholds, float image_tol, float grad_rel_tol) {
  if (!rasterAvx2Available()) GTEST_SKIP() << "this CPU has no AVX2+FMA: only the generic kernels can run here";
  std::mt19937 rng(7);
  const FloatScene scene = randomScene(600, rng);
  const CameraIntrinsics cam = camera();
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  T_world_camera.translation() = Eigen::Vector3d(0.05, -0.03, 0.1);
  const gs::PinholeView<float> view = makePinholeView<float>(T_world_camera, cam);
  const std::size_t npix = static_cast<std::size_t>(cam.width) * cam.height;
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<float> w_color(3 * npix), w_depth(npix);
  for (float& v : w_color) v = u(rng);
  for (float& v : w_depth) v = u(rng);
  const Pass a = renderAndBack(RasterIsa::kGeneric, thresholds, scene, view, w_color, w_depth);
  const Pass b = renderAndBack(RasterIsa::kAvx2, thresholds, scene, view, w_color, w_depth);
  // The scene must actually cover the image, or the comparison says nothing.
  float covered = 0.f;
  for (float v : a.image.alpha) covered += v > 0.5f ? 1.f : 0.f;
  ASSERT_GT(covered, 0.5f * static_cast<float>(npix));
  EXPECT_LE(maxAbsDiff(a.image.color, b.image.color), image_tol);
  EXPECT_LE(maxAbsDiff(a.image.alpha, b.image.alpha), image_tol);
  EXPECT_LE(maxAbsDiff(a.image.depth, b.image.depth), 4.f * image_tol);  // depth up to ~4 m
  EXPECT_LE(maxRelDiff(a.grads.position, b.grads.position), grad_rel_tol);
  EXPECT_LE(maxRelDiff(a.grads.log_scale, b.grads.log_scale), grad_rel_tol);
  EXPECT_LE(maxRelDiff(a.grads.rotation, b.grads.rotation), grad_rel_tol);
  EXPECT_LE(maxRelDiff(a.grads.opacity_logit, b.grads.opacity_logit), grad_rel_tol);
  EXPECT_LE(maxRelDiff(a.grads.sh, b.grads.sh), grad_rel_tol);
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(a.grads.pose[k], b.grads.pose[k], grad_rel_tol * std::max(1.f, std::abs(a.grads.pose[k])));
  }
}

// Smooth settings: the two builds differ only by FMA contraction and the order of additions
// across SIMD lanes (float, ~1e-7 per operation, a few hundred operations per pixel): 1e-5 on
// images in [0, 1], 1e-4 of each gradient block's largest magnitude.
TEST(RasterIsa, Avx2MatchesGenericToRounding) { compareIsas(false, 1e-5f, 1e-4f); }

// Default thresholds: a rounding difference can flip a pixel's alpha >= 1/255 or early-stop
// decision, which moves that pixel by at most one Gaussian's contribution at the threshold
// (alpha 1/255 times a colour <= ~1.5): 0.006 on images; gradients keep 1e-3 relative.
TEST(RasterIsa, Avx2MatchesGenericWithThresholds) { compareIsas(true, 6e-3f, 1e-3f); }

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
