/// Gradient checks of the rasterizer: analytic backward vs central differences, in double, on
/// random small scenes, for every parameter type and the camera pose.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/common/camera.h"
#include "dypho/mapping/rasterizer.h"
#include "gaussian_params_storage.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

using Scene = GaussianParamsStorage<double>;

Scene randomScene(int n, int degree, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Scene s;
  s.n = n;
  s.sh_degree = degree;
  const int K3 = 3 * (degree + 1) * (degree + 1);
  for (int i = 0; i < n; ++i) {
    // In front of the camera (identity-ish pose below), inside the view.
    s.pos.insert(s.pos.end(), {0.5 * u(rng), 0.4 * u(rng), 3.0 + 0.8 * u(rng)});
    s.scale.insert(s.scale.end(),
                   {std::log(0.15 + 0.1 * u(rng)), std::log(0.12 + 0.08 * u(rng)), std::log(0.1 + 0.05 * u(rng))});
    s.rot.insert(s.rot.end(), {1.0 + 0.3 * u(rng), 0.5 * u(rng), 0.5 * u(rng), 0.5 * u(rng)});
    s.opa.push_back(-0.5 + 1.0 * u(rng));
    for (int k = 0; k < K3; ++k) s.sh.push_back(k < 3 ? 0.8 * u(rng) : 0.15 * u(rng));
  }
  return s;
}

/// Exact-coverage settings: no footprint cut-off, no alpha threshold and no early stop, so the
/// rendered images are smooth functions of the parameters (the thresholds are discontinuities
/// that central differences cannot see through; their gradient is zero by definition).
RasterSettings smoothSettings() {
  RasterSettings s;
  s.radius_sigma = 1e3;
  s.min_alpha = 0.0;
  s.min_transmittance = 0.0;
  return s;
}

struct Weights {
  std::vector<double> color, depth, alpha;
};

double loss(Rasterizer<double>& r, const Scene& s, const gs::PinholeView<double>& view, const Weights& w) {
  RenderResult<double> out;
  r.forward(s.view(), view, out);
  double L = 0;
  for (std::size_t i = 0; i < out.color.size(); ++i) L += w.color[i] * out.color[i];
  for (std::size_t i = 0; i < out.depth.size(); ++i) L += w.depth[i] * out.depth[i] + w.alpha[i] * out.alpha[i];
  return L;
}

gs::PinholeView<double> perturbedView(const Eigen::Isometry3d& T_cw, const CameraIntrinsics& cam,
                                      const Eigen::Matrix<double, 6, 1>& d) {
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  const double angle = d.tail<3>().norm();
  if (angle > 0) E.linear() = Eigen::AngleAxisd(angle, d.tail<3>() / angle).toRotationMatrix();
  E.translation() = d.head<3>();
  return makePinholeView<double>((E * T_cw).inverse(), cam);
}

/// ||a - n|| / ||n|| over one parameter type (robust to individual near-zero entries).
double relError(const std::vector<double>& a, const std::vector<double>& n) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    num += (a[i] - n[i]) * (a[i] - n[i]);
    den += n[i] * n[i];
  }
  return std::sqrt(num) / std::max(std::sqrt(den), 1e-12);
}

class GradientCheck : public ::testing::TestWithParam<int> {};

TEST_P(GradientCheck, AnalyticMatchesCentralDifferences) {
  const int degree = GetParam();
  std::mt19937 rng(1234 + degree);
  ThreadPool pool(2);
  Rasterizer<double> raster(&pool, smoothSettings());
  CameraIntrinsics cam;
  cam.width = 40;  // three tiles across and two down (partial tiles included)
  cam.height = 24;
  cam.fx = cam.fy = 30.0;
  cam.cx = 19.5;
  cam.cy = 11.5;
  Eigen::Isometry3d T_cw = Eigen::Isometry3d::Identity();
  T_cw.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  T_cw.translation() = Eigen::Vector3d(0.05, -0.03, 0.1);
  const auto view = makePinholeView<double>(T_cw.inverse(), cam);
  Scene s = randomScene(6, degree, rng);
  const std::size_t npix = static_cast<std::size_t>(cam.width) * cam.height;
  Weights w;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (std::size_t i = 0; i < 3 * npix; ++i) w.color.push_back(u(rng));
  for (std::size_t i = 0; i < npix; ++i) {
    w.depth.push_back(u(rng));
    w.alpha.push_back(u(rng));
  }
  RenderResult<double> out;
  raster.forward(s.view(), view, out);
  GaussianGrads<double> g;
  PixelGrads<double> pg{w.color.data(), w.depth.data(), w.alpha.data()};
  raster.backward(pg, g);

  const double eps = 1e-6;
  auto numeric = [&](std::vector<double>& param) {
    std::vector<double> n(param.size());
    for (std::size_t i = 0; i < param.size(); ++i) {
      const double keep = param[i];
      param[i] = keep + eps;
      const double lp = loss(raster, s, view, w);
      param[i] = keep - eps;
      const double lm = loss(raster, s, view, w);
      param[i] = keep;
      n[i] = (lp - lm) / (2 * eps);
    }
    return n;
  };
  // Bound 1e-3 (the acceptance bound). Central differences in double with eps = 1e-6 have
  // truncation error ~eps^2 * f''' and rounding ~1e-16 * |L| / eps ~ 1e-9 relative: far below.
  const struct {
    const char* name;
    std::vector<double>* param;
    std::vector<double>* grad;
  } blocks[] = {{"position", &s.pos, &g.position},
                {"log_scale", &s.scale, &g.log_scale},
                {"rotation", &s.rot, &g.rotation},
                {"opacity_logit", &s.opa, &g.opacity_logit},
                {"sh", &s.sh, &g.sh}};
  for (const auto& b : blocks) {
    const std::vector<double> n = numeric(*b.param);
    const double e = relError(*b.grad, n);
    RecordProperty(std::string("rel_error_") + b.name, std::to_string(e));
    std::printf("degree %d %-14s relative error %.2e\n", degree, b.name, e);
    EXPECT_LE(e, 1e-3) << b.name;
  }
  std::vector<double> pose_a(g.pose, g.pose + 6), pose_n(6);
  for (int j = 0; j < 6; ++j) {
    Eigen::Matrix<double, 6, 1> d = Eigen::Matrix<double, 6, 1>::Zero();
    d[j] = eps;
    RenderResult<double> o;
    const double lp = loss(raster, s, perturbedView(T_cw, cam, d), w);
    d[j] = -eps;
    const double lm = loss(raster, s, perturbedView(T_cw, cam, d), w);
    pose_n[j] = (lp - lm) / (2 * eps);
  }
  const double e = relError(pose_a, pose_n);
  std::printf("degree %d %-14s relative error %.2e\n", degree, "pose", e);
  EXPECT_LE(e, 1e-3) << "pose";
}

INSTANTIATE_TEST_SUITE_P(ShDegrees, GradientCheck, ::testing::Values(0, 1, 2, 3));

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
