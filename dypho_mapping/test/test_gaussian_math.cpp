/// Projection, covariance and single-Gaussian rendering against closed forms; the tiled
/// rasterizer against a per-pixel reference; Adam step.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include "dypho/mapping/adam.h"
#include "dypho/mapping/gaussian_map.h"
#include "dypho/common/camera.h"
#include "dypho/mapping/rasterizer.h"
#include "gaussian_params_storage.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

CameraIntrinsics testCamera() {
  CameraIntrinsics c;
  c.width = 64;
  c.height = 48;
  c.fx = 50.0;
  c.fy = 55.0;
  c.cx = 31.5;
  c.cy = 23.5;
  return c;
}

TEST(GaussianMath, Covariance3dIsRotatedDiagonal) {
  const double q[4] = {0.9, 0.2, -0.3, 0.1};
  const double ls[3] = {std::log(0.1), std::log(0.2), std::log(0.05)};
  const gs::Mat3<double> C = gs::covariance3d(ls, q);
  const Eigen::Matrix3d R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  const Eigen::Matrix3d expected = R * Eigen::Vector3d(0.01, 0.04, 0.0025).asDiagonal() * R.transpose();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(C.m[i][j], expected(i, j), 1e-12);  // double round-off
}

TEST(GaussianMath, ProjectionOfIsotropicGaussianOnAxis) {
  const auto view = makePinholeView<double>(Eigen::Isometry3d::Identity(), testCamera());
  const double pos[3] = {0.2, -0.1, 2.0}, q[4] = {1, 0, 0, 0}, sigma = 0.05;
  const double ls[3] = {std::log(sigma), std::log(sigma), std::log(sigma)};
  const double sh[3] = {0, 0, 0};
  gs::Projected<double> p;
  ASSERT_TRUE(gs::projectGaussian(view, pos, ls, q, 0.0, sh, 0, 3.0, 0.0, p));
  EXPECT_NEAR(p.mean_u, 50.0 * 0.2 / 2.0 + 31.5, 1e-12);
  EXPECT_NEAR(p.mean_v, 55.0 * -0.1 / 2.0 + 23.5, 1e-12);
  EXPECT_DOUBLE_EQ(p.depth_m, 2.0);
  EXPECT_DOUBLE_EQ(p.opacity, 0.5);
  EXPECT_NEAR(p.color[0], 0.5, 1e-15);
  // Closed form: Sigma2 = J Sigma J^T + 0.3 I with J = [[fx/z, 0, -fx x/z^2], [0, fy/z, -fy y/z^2]].
  const double z = 2.0, s2 = sigma * sigma;
  const double a = (50.0 / z) * (50.0 / z) * s2 + std::pow(50.0 * 0.2 / (z * z), 2) * s2 + 0.3;
  const double b = (50.0 * 0.2 / (z * z)) * (55.0 * -0.1 / (z * z)) * s2;
  const double c = (55.0 / z) * (55.0 / z) * s2 + std::pow(55.0 * 0.1 / (z * z), 2) * s2 + 0.3;
  const double det = a * c - b * b;
  EXPECT_NEAR(p.conic_a, c / det, 1e-12);
  EXPECT_NEAR(p.conic_b, -b / det, 1e-12);
  EXPECT_NEAR(p.conic_c, a / det, 1e-12);
}

TEST(GaussianMath, BehindCameraIsCulled) {
  const auto view = makePinholeView<double>(Eigen::Isometry3d::Identity(), testCamera());
  const double pos[3] = {0, 0, -1}, q[4] = {1, 0, 0, 0}, ls[3] = {-3, -3, -3}, sh[3] = {0, 0, 0};
  gs::Projected<double> p;
  EXPECT_FALSE(gs::projectGaussian(view, pos, ls, q, 0.0, sh, 0, 3.0, 0.0, p));
}

/// Loss of the camera-point step: L = g.mean_u u + g.mean_v v + g.depth z + <gj, J(p_c)>.
double cameraPointLoss(const gs::PinholeView<double>& view, const double* pc, const gs::ScreenJacobianGrad<double>& gj,
                       const gs::ScreenGrad<double>& g) {
  const gs::ProjectionJacobian<double> J = gs::projectionJacobian(view, pc);
  const double u = view.fx * pc[0] / pc[2] + view.cx, v = view.fy * pc[1] / pc[2] + view.cy;
  return g.mean_u * u + g.mean_v * v + g.depth * pc[2] + gj.gJ00 * J.J00 + gj.gJ02 * J.J02 + gj.gJ11 * J.J11 +
         gj.gJ12 * J.J12;
}

TEST(GaussianMath, CameraPointBackwardMatchesCentralDifferences) {
  const auto view = makePinholeView<double>(Eigen::Isometry3d::Identity(), testCamera());
  gs::ScreenGrad<double> g{};
  g.mean_u = 0.7;
  g.mean_v = -1.3;
  g.depth = 0.4;
  gs::ScreenJacobianGrad<double> gj{};
  gj.gJ00 = 0.2, gj.gJ02 = -0.5, gj.gJ11 = 0.9, gj.gJ12 = 0.3;
  const double pc[3] = {0.3, -0.2, 1.7};  // inside the clamp: every J entry depends on p_c
  ASSERT_FALSE(gs::projectionJacobian(view, pc).clamp_x);
  ASSERT_FALSE(gs::projectionJacobian(view, pc).clamp_y);
  double gpc[3];
  gs::cameraPointBackward(view, gs::projectionJacobian(view, pc), pc, gj, g, gpc);
  const double h = 1e-6;
  for (int i = 0; i < 3; ++i) {
    double plus[3] = {pc[0], pc[1], pc[2]}, minus[3] = {pc[0], pc[1], pc[2]};
    plus[i] += h;
    minus[i] -= h;
    const double numeric = (cameraPointLoss(view, plus, gj, g) - cameraPointLoss(view, minus, gj, g)) / (2 * h);
    EXPECT_NEAR(gpc[i], numeric, 1e-6 * std::max(1.0, std::abs(numeric))) << "p_c[" << i << "]";  // O(h^2) + round-off
  }
}

TEST(GaussianMath, ScreenJacobianBackwardIsTheAdjointOfJTimesR) {
  // L = <GA, J R>: dL/dJ = GA R^T (four entries), dL/dR = J^T GA; L is linear in each, so
  // one-sided differences with a step of 1 are exact up to round-off (|L| < 100: 1e-9).
  auto view = makePinholeView<double>(Eigen::Isometry3d::Identity(), testCamera());
  const double R[3][3] = {{0.9, -0.1, 0.3}, {0.2, 0.8, -0.4}, {-0.3, 0.5, 0.7}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) view.R_cw[i][j] = R[i][j];
  const double GA[2][3] = {{0.5, -1.0, 0.25}, {2.0, 0.1, -0.7}};
  gs::ProjectionJacobian<double> J{};
  J.J00 = 30.0, J.J02 = -4.0, J.J11 = 33.0, J.J12 = 2.5;
  auto loss = [&](const gs::PinholeView<double>& cam, const gs::ProjectionJacobian<double>& Jm) {
    double A[2][3];
    gs::screenJacobianWorld(cam, Jm, A);
    double l = 0.0;
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 3; ++j) l += GA[i][j] * A[i][j];
    return l;
  };
  const gs::ScreenJacobianGrad<double> gj = gs::screenJacobianBackward(view, J, GA);
  const double l0 = loss(view, J);
  using PJ = gs::ProjectionJacobian<double>;
  double PJ::*const entries[4] = {&PJ::J00, &PJ::J02, &PJ::J11, &PJ::J12};
  const double expected_gJ[4] = {gj.gJ00, gj.gJ02, gj.gJ11, gj.gJ12};
  for (int e = 0; e < 4; ++e) {
    gs::ProjectionJacobian<double> Jp = J;
    Jp.*entries[e] += 1.0;
    EXPECT_NEAR(expected_gJ[e], loss(view, Jp) - l0, 1e-9) << "J entry " << e;
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      auto moved = view;
      moved.R_cw[i][j] += 1.0;
      EXPECT_NEAR(gj.GW[i][j], loss(moved, J) - l0, 1e-9) << "R_cw(" << i << ", " << j << ")";
    }
}

TEST(GaussianMath, FastExpMatchesStdExp) {
  // Bound 1e-6: polynomial truncation < 1.2e-7 plus float rounding of ~8 operations (each
  // <= 6e-8) in blendExp, in std::exp and in the division here.
  for (float x = -20.f; x <= 5.f; x += 0.001f) {
    EXPECT_NEAR(gs::blendExp(x) / std::exp(x), 1.f, 1e-6f) << x;
  }
}

TEST(Rasterizer, SingleGaussianMatchesAnalyticValue) {
  ThreadPool pool(2);
  Rasterizer<double> raster(&pool);
  const CameraIntrinsics cam = testCamera();
  GaussianParamsStorage<double> g;
  g.n = 1;
  g.sh_degree = 0;
  g.pos = {0.1, 0.05, 1.5};
  g.scale = {std::log(0.04), std::log(0.03), std::log(0.02)};
  g.rot = {0.95, 0.1, 0.2, -0.1};
  g.opa = {1.2};
  g.sh = {(0.8 - 0.5) / gs::kShC0, (0.3 - 0.5) / gs::kShC0, (0.6 - 0.5) / gs::kShC0};
  const auto view = makePinholeView<double>(Eigen::Isometry3d::Identity(), cam);
  RenderResult<double> out;
  raster.forward(g.view(), view, out);
  gs::Projected<double> p;
  ASSERT_TRUE(gs::projectGaussian(view, g.pos.data(), g.scale.data(), g.rot.data(), g.opa[0], g.sh.data(), 0, 3.0,
                                  1.0 / 255, p));
  const double o = 1.0 / (1.0 + std::exp(-1.2));
  int checked = 0;
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      const double dx = p.mean_u - x, dy = p.mean_v - y;
      const double power = -0.5 * (p.conic_a * dx * dx + p.conic_c * dy * dy) - p.conic_b * dx * dy;
      double alpha = std::min(0.99, o * std::exp(power));
      if (alpha < 1.0 / 255) alpha = 0;  // below the threshold the pixel skips the Gaussian
      const std::size_t i = static_cast<std::size_t>(y) * cam.width + x;
      const std::size_t n = static_cast<std::size_t>(cam.width) * cam.height;
      // Tolerance 1e-12: same double formula, only the evaluation order differs.
      EXPECT_NEAR(out.alpha[i], alpha, 1e-12);
      EXPECT_NEAR(out.color[i], alpha * 0.8, 1e-12);
      EXPECT_NEAR(out.color[n + i], alpha * 0.3, 1e-12);
      EXPECT_NEAR(out.color[2 * n + i], alpha * 0.6, 1e-12);
      EXPECT_NEAR(out.depth[i], alpha * 1.5, 1e-12);
      checked += alpha > 0.1;
    }
  }
  EXPECT_GT(checked, 10);  // the Gaussian really covers pixels
}

TEST(GaussianMath, MayReachImageNeverRejectsAVisibleGaussian) {
  // Random Gaussians in front of, beside and behind the camera, from tiny to huge: the cheap
  // pre-test must accept every one that projects onto the image (what the rasterizer keeps), and
  // must reject the ones far off screen (else it saves nothing).
  const CameraIntrinsics cam = testCamera();
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  T_wc.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  T_wc.translation() = Eigen::Vector3d(0.2, -0.1, 0.3);
  const auto view = makePinholeView<float>(T_wc, cam);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  int visible = 0, rejected_off_screen = 0;
  for (int i = 0; i < 200000; ++i) {
    const float pos[3] = {6.f * u(rng), 6.f * u(rng), 6.f * u(rng)};
    const float ls[3] = {-5.f + 3.5f * (u(rng) + 1.f), -5.f + 3.5f * (u(rng) + 1.f), -5.f + 3.5f * (u(rng) + 1.f)};
    const float q[4] = {u(rng), u(rng), u(rng), u(rng)};
    const float sh[3] = {0.f, 0.f, 0.f};
    const float logit = 3.f * u(rng);
    const bool may = gs::mayReachImage(view, pos[0], pos[1], pos[2], ls[0], ls[1], ls[2], 3.f);
    gs::Projected<float> p;
    if (gs::projectGaussian(view, pos, ls, q, logit, sh, 0, 3.f, 1.f / 255.f, p)) {
      const float r = p.radius_px;
      const bool on_screen = p.mean_u + r >= -0.5f && p.mean_u - r <= cam.width - 0.5f && p.mean_v + r >= -0.5f &&
                             p.mean_v - r <= cam.height - 0.5f;
      if (on_screen) {
        ++visible;
        ASSERT_TRUE(may) << "rejected a visible Gaussian " << i << " at (" << p.mean_u << ", " << p.mean_v
                         << ") radius " << r;
      } else {
        rejected_off_screen += may ? 0 : 1;
      }
    }
  }
  EXPECT_GT(visible, 1000);
  EXPECT_GT(rejected_off_screen, 10000);
}

/// Per-pixel front-to-back compositing of every Gaussian (no tiles, no boxes): the definition the
/// tiled rasterizer implements. Returns how many pixels stopped early.
int referenceRender(const GaussianParamsView<double>& v, const gs::PinholeView<double>& view, const RasterSettings& st,
                    RenderResult<double>& out) {
  const int W = view.width, H = view.height;
  const std::size_t npix = static_cast<std::size_t>(W) * H;
  out.color.assign(3 * npix, 0.0);
  out.depth.assign(npix, 0.0);
  out.alpha.assign(npix, 0.0);
  std::vector<gs::Projected<double>> pr;
  const int K3 = 3 * gs::shCoeffCount(v.sh_degree);
  for (int i = 0; i < v.count; ++i) {
    gs::Projected<double> p;
    if (gs::projectGaussian(view, v.position + 3 * i, v.log_scale + 3 * i, v.rotation + 4 * i, v.opacity_logit[i],
                            v.sh + K3 * i, v.sh_degree, st.radius_sigma, st.min_alpha, p)) {
      pr.push_back(p);
    }
  }
  std::stable_sort(pr.begin(), pr.end(), [](const auto& a, const auto& b) { return a.depth_m < b.depth_m; });
  int stopped = 0;
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      double T = 1.0, c[3] = {0, 0, 0}, d = 0.0;
      for (const auto& p : pr) {
        const double dx = p.mean_u - x, dy = p.mean_v - y;
        const double power = -0.5 * (p.conic_a * dx * dx + p.conic_c * dy * dy) - p.conic_b * dx * dy;
        if (power > 0) continue;
        const double alpha = std::min(gs::kMaxAlpha, p.opacity * std::exp(power));
        if (alpha < st.min_alpha) continue;
        const double test_T = T * (1.0 - alpha);
        if (test_T < st.min_transmittance) {
          ++stopped;
          break;
        }
        for (int ch = 0; ch < 3; ++ch) c[ch] += alpha * T * p.color[ch];
        d += alpha * T * p.depth_m;
        T = test_T;
      }
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      for (int ch = 0; ch < 3; ++ch) out.color[ch * npix + i] = c[ch];
      out.depth[i] = d;
      out.alpha[i] = 1.0 - T;
    }
  }
  return stopped;
}

TEST(Rasterizer, TiledForwardMatchesPerPixelReference) {
  // A random scene dense enough for early stops, Gaussians across tile borders and off screen, an
  // image with partial tiles. The footprint is the alpha threshold (radius_sigma large), so the
  // tiled result must equal the per-pixel definition; tolerance 1e-9: both in double, they differ
  // only in the order of the same operations.
  CameraIntrinsics cam = testCamera();
  cam.width = 70;
  cam.height = 45;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 800, degree = 2, K3 = 27;
  std::vector<double> pos, ls, rot, opa, sh;
  for (int i = 0; i < n; ++i) {
    pos.insert(pos.end(), {1.6 * u(rng), 1.2 * u(rng), 2.0 + 0.8 * u(rng)});
    ls.insert(ls.end(), {std::log(0.12) + 0.8 * u(rng), std::log(0.1) + 0.8 * u(rng), std::log(0.03) + 0.5 * u(rng)});
    rot.insert(rot.end(), {u(rng), u(rng), u(rng), u(rng)});
    opa.push_back(2.5 + 2.0 * u(rng));
    for (int k = 0; k < K3; ++k) sh.push_back(k < 3 ? u(rng) : 0.2 * u(rng));
  }
  const GaussianParamsView<double> v{pos.data(), ls.data(), rot.data(), opa.data(), sh.data(), n, degree};
  RasterSettings st;
  st.radius_sigma = 1e3;
  ThreadPool pool(2);
  Rasterizer<double> raster(&pool, st);
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  T_wc.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const auto view = makePinholeView<double>(T_wc, cam);
  RenderResult<double> out, ref;
  raster.forward(v, view, out);
  const int stopped = referenceRender(v, view, st, ref);
  for (std::size_t i = 0; i < ref.alpha.size(); ++i) {
    ASSERT_NEAR(out.alpha[i], ref.alpha[i], 1e-9) << i;
    ASSERT_NEAR(out.depth[i], ref.depth[i], 1e-9) << i;
  }
  for (std::size_t i = 0; i < ref.color.size(); ++i) ASSERT_NEAR(out.color[i], ref.color[i], 1e-9) << i;
  EXPECT_GT(stopped, 100);  // early stops exercised
  EXPECT_LT(stopped, static_cast<int>(ref.alpha.size()) / 2);
}

TEST(Rasterizer, FrontGaussianOccludesBackOne) {
  ThreadPool pool(1);
  Rasterizer<float> raster(&pool);
  CameraIntrinsics cam = testCamera();
  GaussianMap map(0, 4);
  GaussianInit g;
  g.log_scale = Eigen::Vector3f::Constant(std::log(0.5f));  // >= 8 px std dev: G ~ 1 at the centre
  g.opacity_logit = 10.f;                                   // opacity ~1 -> alpha clamps at 0.99
  g.position_w = {0, 0, 3};
  g.sh = {rgbToShDc(0.f), rgbToShDc(0.f), rgbToShDc(1.f)};
  map.add(g);
  g.opacity_logit = std::log(0.7f / 0.3f);  // front: alpha 0.7
  g.position_w = {0, 0, 1};
  g.sh = {rgbToShDc(1.f), rgbToShDc(0.f), rgbToShDc(0.f)};
  map.add(g);  // added second but nearer: depth sorting must put it first
  GaussianParamsView<float> v{map.data(kParamPosition),
                              map.data(kParamLogScale),
                              map.data(kParamRotation),
                              map.data(kParamOpacity),
                              map.data(kParamSh),
                              2,
                              0};
  RenderResult<float> out;
  raster.forward(v, makePinholeView<float>(Eigen::Isometry3d::Identity(), cam), out);
  const std::size_t c = 24 * 64 + 32, n = 64 * 48;
  // Tolerance 2e-3: at the centre pixel (half a pixel off the mean) G differs from 1 by < 1e-3.
  EXPECT_NEAR(out.color[c], 0.7f, 2e-3f);                             // red in front
  EXPECT_NEAR(out.color[2 * n + c], 0.3f * 0.99f, 2e-3f);             // blue behind, through T = 0.3
  EXPECT_NEAR(out.depth[c], 0.7f * 1.f + 0.3f * 0.99f * 3.f, 6e-3f);  // D = sum d_i alpha_i T_i
  EXPECT_NEAR(out.alpha[c], 0.7f + 0.3f * 0.99f, 2e-3f);
}

TEST(Adam, FirstTwoStepsMatchClosedForm) {
  GaussianMap map(0, 2);
  map.add(GaussianInit());
  AdamLearningRates lr;
  lr.position = 0.1;
  Adam adam(lr);
  GaussianGrads<float> g;
  g.position = {2.f, -3.f, 0.f};
  g.log_scale.assign(3, 0.f);
  g.rotation.assign(4, 0.f);
  g.opacity_logit.assign(1, 0.f);
  g.sh.assign(3, 0.f);
  adam.step(map, g);
  // Step 1: mhat = g, vhat = g^2 -> x -= lr * sign(g).
  EXPECT_NEAR(map.data(kParamPosition)[0], -0.1f, 1e-6f);
  EXPECT_NEAR(map.data(kParamPosition)[1], 0.1f, 1e-6f);
  EXPECT_EQ(map.data(kParamPosition)[2], 0.f);
  g.position = {1.f, 0.f, 0.f};
  adam.step(map, g);
  const double m = 0.9 * 0.1 * 2 + 0.1 * 1, v = 0.999 * 0.001 * 4 + 0.001 * 1;
  const double expected = -0.1 - 0.1 * (m / (1 - 0.81)) / std::sqrt(v / (1 - 0.999 * 0.999));
  EXPECT_NEAR(map.data(kParamPosition)[0], expected, 1e-5);  // float arithmetic
  EXPECT_EQ(adam.steps(), 2);
  g.position.pop_back();
  EXPECT_THROW(adam.step(map, g), std::invalid_argument);
}

TEST(GaussianMap, CapacityIdsAndCompaction) {
  GaussianMap map(1, 3);
  GaussianInit g;
  for (int i = 0; i < 3; ++i) {
    g.position_w = Eigen::Vector3f::Constant(static_cast<float>(i));
    EXPECT_EQ(map.add(g), i);
  }
  EXPECT_EQ(map.add(g), -1);  // full
  EXPECT_EQ(map.duplicate(0), -1);
  map.removeIf({0, 1, 0});
  ASSERT_EQ(map.size(), 2u);
  EXPECT_EQ(map.ids()[0], 0);
  EXPECT_EQ(map.ids()[1], 2);  // ids survive removal
  EXPECT_EQ(map.data(kParamPosition)[3], 2.f);
  EXPECT_EQ(map.duplicate(1), 2);
  EXPECT_EQ(map.ids()[2], 3);  // new id, never reused
  EXPECT_EQ(map.data(kParamPosition)[6], 2.f);
  EXPECT_THROW(map.removeIf({1}), std::invalid_argument);
  EXPECT_THROW(GaussianMap(4, 10), std::invalid_argument);
}

TEST(GaussianMap, TransformAnchoredMovesOnlyThatKeyframe) {
  GaussianMap map(0, 4);
  GaussianInit g;
  g.position_w = {1, 0, 0};
  g.anchor_keyframe_id = 7;
  map.add(g);
  g.anchor_keyframe_id = 8;
  map.add(g);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0, 0, 1);
  EXPECT_EQ(map.transformAnchored(7, T), 1u);
  EXPECT_NEAR(map.data(kParamPosition)[0], 0.f, 1e-6f);
  EXPECT_NEAR(map.data(kParamPosition)[1], 1.f, 1e-6f);
  EXPECT_NEAR(map.data(kParamPosition)[2], 1.f, 1e-6f);
  EXPECT_EQ(map.data(kParamPosition)[3], 1.f);  // the other keyframe's Gaussian did not move
  const float* q = map.data(kParamRotation);
  EXPECT_NEAR(q[0], std::cos(M_PI / 4), 1e-6);
  EXPECT_NEAR(q[3], std::sin(M_PI / 4), 1e-6);
}

/// Colour (before the 0.5 offset and the clamp) of SH coefficients `sh` in direction d.
Eigen::Vector3d shColour(const std::vector<double>& sh, int degree, const Eigen::Vector3d& d) {
  double b[16];
  const double dir[3] = {d.x(), d.y(), d.z()};
  gs::shBasis(degree, dir, b);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int k = 0; k < gs::shCoeffCount(degree); ++k)
    for (int ch = 0; ch < 3; ++ch) c[ch] += b[k] * sh[3 * k + ch];
  return c;
}

void toArray(const Eigen::Matrix3d& R, double out[3][3]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[r][c] = R(r, c);
}

TEST(GaussianSh, RotationTurnsTheColourWithTheGaussian) {
  // c'(R d) = c(d) for random rotations and directions; identity is a no-op; composition
  // R2 (R1 s) = (R2 R1) s. Tolerance 1e-12: exact quadrature in double, only rounding differs.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int degree = 1; degree <= 3; ++degree) {
    const int K = gs::shCoeffCount(degree);
    std::vector<double> sh(3 * K);
    for (auto& v : sh) v = u(rng);
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::Matrix3d R1 = Eigen::Quaterniond(Eigen::Vector4d::Random().normalized()).toRotationMatrix();
      const Eigen::Matrix3d R2 = Eigen::Quaterniond(Eigen::Vector4d::Random().normalized()).toRotationMatrix();
      double a1[3][3], a2[3][3], a21[3][3];
      toArray(R1, a1);
      toArray(R2, a2);
      toArray(R2 * R1, a21);
      gs::ShRotation<double> m1, m2, m21;
      gs::shRotation(a1, degree, m1);
      gs::shRotation(a2, degree, m2);
      gs::shRotation(a21, degree, m21);
      std::vector<double> s1 = sh;
      gs::rotateSh(m1, degree, s1.data());
      for (int j = 0; j < 20; ++j) {
        const Eigen::Vector3d d = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
        const Eigen::Vector3d before = shColour(sh, degree, d), after = shColour(s1, degree, R1 * d);
        ASSERT_LT((before - after).norm(), 1e-12) << "degree " << degree;
      }
      std::vector<double> s12 = s1, s21 = sh;
      gs::rotateSh(m2, degree, s12.data());
      gs::rotateSh(m21, degree, s21.data());
      for (int k = 0; k < 3 * K; ++k) ASSERT_NEAR(s12[k], s21[k], 1e-12) << "degree " << degree;
      EXPECT_GT(std::abs(s1[3] - sh[3]) + std::abs(s1[4] - sh[4]), 1e-3);  // it did rotate
    }
    double I[3][3];
    toArray(Eigen::Matrix3d::Identity(), I);
    gs::ShRotation<double> mi;
    gs::shRotation(I, degree, mi);
    std::vector<double> si = sh;
    gs::rotateSh(mi, degree, si.data());
    for (int k = 0; k < 3 * K; ++k) EXPECT_NEAR(si[k], sh[k], 1e-14) << "degree " << degree;
  }
}

TEST(GaussianSh, ReanchoredGaussianRendersTheSameFromTheMovedCamera) {
  // A view-dependent Gaussian, re-anchored by T (a loop-closure correction), seen from the camera
  // moved by T, renders the same colour as before; without rotating its SH it would not (checked,
  // so the test can fail). Tolerance 2e-5: float rendering of the same Gaussian from a different
  // pose (rounding in the projection, the rotations and the SH products).
  const CameraIntrinsics cam = testCamera();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.8, 0.5).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.4, -0.2, 0.7);
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  T_wc.translation() = Eigen::Vector3d(0.3, 0.1, -0.2);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  ThreadPool pool(1);
  for (int degree = 1; degree <= 3; ++degree) {
    GaussianMap map(degree, 2), unrotated(degree, 2);
    GaussianInit g;
    g.position_w = {0.35f, 0.05f, 1.4f};
    g.log_scale = {std::log(0.05f), std::log(0.04f), std::log(0.03f)};
    g.rotation_wxyz = {0.9f, 0.2f, -0.1f, 0.3f};
    g.opacity_logit = 1.5f;
    g.anchor_keyframe_id = 3;
    g.sh.assign(3 * map.shCoeffs(), 0.f);
    for (int ch = 0; ch < 3; ++ch) g.sh[ch] = rgbToShDc(0.5f);
    for (int k = 3; k < 3 * map.shCoeffs(); ++k) g.sh[k] = 0.25f * u(rng);  // view-dependent, colour stays > 0
    map.add(g);
    Rasterizer<float> raster(&pool);
    auto view = [&](const GaussianMap& m) {
      return GaussianParamsView<float>{m.data(kParamPosition),
                                       m.data(kParamLogScale),
                                       m.data(kParamRotation),
                                       m.data(kParamOpacity),
                                       m.data(kParamSh),
                                       1,
                                       degree};
    };
    RenderResult<float> before, after;
    raster.forward(view(map), makePinholeView<float>(T_wc, cam), before);
    // Re-anchor; the reference copy moves position and orientation only.
    const Eigen::Quaternionf qT(T.linear().cast<float>());
    GaussianInit moved = g;
    moved.position_w = T.cast<float>() * g.position_w;
    const Eigen::Quaternionf qm =
        qT * Eigen::Quaternionf(g.rotation_wxyz[0], g.rotation_wxyz[1], g.rotation_wxyz[2], g.rotation_wxyz[3]);
    moved.rotation_wxyz = {qm.w(), qm.x(), qm.y(), qm.z()};
    unrotated.add(moved);
    ASSERT_EQ(map.transformAnchored(3, T), 1u);
    raster.forward(view(map), makePinholeView<float>(T * T_wc, cam), after);
    double max_diff = 0.0, sum_alpha = 0.0;
    for (std::size_t i = 0; i < before.color.size(); ++i)
      max_diff = std::max(max_diff, double(std::abs(before.color[i] - after.color[i])));
    for (float a : before.alpha) sum_alpha += a;
    EXPECT_GT(sum_alpha, 5.0) << "the Gaussian must cover pixels";
    EXPECT_LT(max_diff, 2e-5) << "degree " << degree;
    RenderResult<float> stale;
    raster.forward(view(unrotated), makePinholeView<float>(T * T_wc, cam), stale);
    double stale_diff = 0.0;
    for (std::size_t i = 0; i < before.color.size(); ++i)
      stale_diff = std::max(stale_diff, double(std::abs(before.color[i] - stale.color[i])));
    EXPECT_GT(stale_diff, 1e-2) << "degree " << degree << ": without SH rotation the colour should change";
  }
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
