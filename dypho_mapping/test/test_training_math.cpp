/// The training on the GPU against GaussianTrainer itself: the device's loss and densify/prune,
/// run on the CPU by the GPU emulator (gpu_emulator.h) in the kernels' order, give the trainer's
/// gradients, exposure gradients and map. Both call training_math.h; what may differ is only
/// the order and precision of the sums (a double sum on the CPU, float sums per GPU thread).
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "dypho/mapping/training_math.h"
#include "gaussian_trainer.h"
#include "gpu_emulator.h"
#include "plane_keyframe.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

constexpr int kW = 40, kH = 30;

/// A keyframe with random colour and depth, a dynamic block and a hole in the depth.
TrainingKeyframe randomKeyframe(std::mt19937& rng) {
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_real_distribution<float> depth(0.5f, 4.f);
  TrainingKeyframe kf;
  kf.id = 3;
  kf.bgr.create(kH, kW, CV_8UC3);
  kf.depth_m.create(kH, kW, CV_32FC1);
  kf.static_mask = cv::Mat(kH, kW, CV_8UC1, cv::Scalar(255));
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      kf.bgr.at<cv::Vec3b>(v, u) = cv::Vec3b(byte(rng), byte(rng), byte(rng));
      kf.depth_m.at<float>(v, u) = depth(rng);
    }
  kf.static_mask(cv::Rect(5, 5, 10, 8)).setTo(0);  // a person
  kf.depth_m(cv::Rect(20, 10, 6, 6)).setTo(0.f);   // no depth
  const float exposure[6] = {0.1f, -0.05f, 0.2f, 0.02f, -0.01f, 0.03f};
  std::copy(exposure, exposure + 6, kf.exposure);
  return kf;
}

RenderResult<float> randomRender(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.f, 1.f);
  RenderResult<float> r;
  r.width = kW;
  r.height = kH;
  r.color.resize(3 * kW * kH);
  r.depth.resize(kW * kH);
  r.alpha.resize(kW * kH);
  for (float& x : r.color) x = u(rng);
  for (float& x : r.depth) x = 0.5f + 3.5f * u(rng);
  for (float& x : r.alpha) x = u(rng);
  return r;
}

/// CudaTrainer::loss without SSIM on the CPU: l1LossKernel's body per pixel, float sums.
struct DeviceLoss {
  double loss = 0.0;
  std::vector<float> g_color, g_depth, g_alpha;
  float exposure_grad[6] = {};
};

DeviceLoss deviceLoss(GaussianTrainer& trainer, const TrainingKeyframe& kf, const RenderResult<float>& r) {
  const TrainingTargetCounts n = trainer.fillTarget(kf);
  const std::size_t npix = static_cast<std::size_t>(kW) * kH;
  const GaussianMapperOptions& o = trainer.options;
  const train::LossParams L = train::lossParams(npix, n.static_pixels, n.depth_pixels, o.lambda_depth, o.alpha_weight,
                                                kf.exposure, /*ssim_follows=*/false);
  DeviceLoss d;
  d.g_color.resize(3 * npix);
  d.g_depth.resize(npix);
  d.g_alpha.resize(npix);
  float sums[train::kLossSums] = {};
  for (std::size_t i = 0; i < npix; ++i) {
    train::l1LossPixel(static_cast<int>(i), L, r.color.data(), r.depth.data(), r.alpha.data(),
                       trainer.target_rgb.data(), trainer.target_depth.data(), trainer.target_mask.data(),
                       d.g_color.data(), d.g_depth.data(), d.g_alpha.data(), sums);
  }
  d.loss = train::lossFromSums(sums, n.static_pixels, n.depth_pixels, o.lambda_depth, o.alpha_weight);
  for (int k = 0; k < 6; ++k) d.exposure_grad[k] = sums[3 + k];
  return d;
}

// The loss and its pixel gradients: the same per-pixel math, so the gradients are equal; the
// loss and the exposure gradients are sums of 1200 terms, in double on the CPU and in float here
// (float's relative rounding over 1200 additions: under 1200 * 6e-8 = 7e-5).
TEST(TrainingMath, DeviceLossIsTheTrainersLoss) {
  std::mt19937 rng(11);
  GaussianMapperOptions o;
  o.exposure_compensation = true;
  o.ssim_weight = 0.0;
  o.num_threads = 1;
  GaussianTrainer trainer(o, ComputeDevice::kCpu);
  const TrainingKeyframe kf = randomKeyframe(rng);
  const RenderResult<float> r = randomRender(rng);
  const double loss = trainer.lossAndGradient(kf, r);
  const DeviceLoss d = deviceLoss(trainer, kf, r);
  ASSERT_GT(loss, 0.1);  // a real comparison: the render is far from the keyframe
  EXPECT_NEAR(d.loss, loss, 1e-4 * loss);
  EXPECT_EQ(d.g_color, trainer.pix_gc);
  EXPECT_EQ(d.g_depth, trainer.pix_gd);
  EXPECT_EQ(d.g_alpha, trainer.pix_ga);
  for (int k = 0; k < 6; ++k) {
    EXPECT_NE(trainer.exposure_grad[k], 0.f) << k;
    EXPECT_NEAR(d.exposure_grad[k], trainer.exposure_grad[k], 1e-4f * std::abs(trainer.exposure_grad[k]) + 1e-7f) << k;
  }
}

/// Gaussians of every kind the rules tell apart, with their densification statistics.
void addGaussians(GaussianTrainer& trainer) {
  struct Row {
    float x, log_scale, opacity_logit, grad_sum;
    int grad_count;
  };
  const float small = std::log(0.01f), large = std::log(0.1f), huge = std::log(0.5f);
  const Row rows[] = {{0.f, small, 2.f, 1.f, 10}, {1.f, large, 2.f, 1.f, 10},  {2.f, small, 2.f, 1e-5f, 10},
                      {3.f, small, 2.f, 1.f, 0},  {4.f, small, -10.f, 0.f, 0}, {5.f, huge, 2.f, 0.f, 0},
                      {6.f, large, 2.f, 1.f, 10}, {7.f, small, 2.f, 1.f, 10},  {8.f, large, 2.f, 1.f, 10}};
  for (const Row& row : rows) {
    GaussianInit g;
    g.position_w = Eigen::Vector3f(row.x, 0.5f * row.x, 2.f);
    g.log_scale = Eigen::Vector3f(row.log_scale, row.log_scale - 0.5f, row.log_scale - 1.f);
    g.rotation_wxyz = Eigen::Vector4f(0.9f, 0.1f * row.x, 0.2f, 0.3f);
    g.opacity_logit = row.opacity_logit;
    ASSERT_GE(trainer.map.add(g), 0);
    trainer.grad_accum.push_back(row.grad_sum);
    trainer.grad_count.push_back(row.grad_count);
  }
}

/// The trainer's map blocks against the emulated device state, value for value.
void expectSameState(const GaussianMap& map, const gpu_emulator::HostState& st) {
  ASSERT_EQ(map.size(), st.n);
  for (int p = 0; p < kNumGaussianParams; ++p) {
    const std::vector<float> host(map.data(p), map.data(p) + map.size() * map.width(p));
    EXPECT_EQ(host, st.params[p]) << "block " << p;
  }
}

// Densify and prune: the device pass (decide, spawn, prune, compact) on the trainer's state with
// the trainer's settings and seed gives the trainer's map exactly, also where the capacity cuts
// the children (a split that does not fit keeps its parent).
TEST(TrainingMath, DeviceDensifyIsTheTrainers) {
  for (const std::size_t capacity : {std::size_t{100}, std::size_t{12}}) {
    GaussianMapperOptions o;
    o.max_gaussians = capacity;
    o.num_threads = 1;
    GaussianTrainer trainer(o, ComputeDevice::kCpu);
    addGaussians(trainer);
    gpu_emulator::HostState st;
    const TrainingStateView view = trainer.stateView();
    st.n = view.count;
    for (int p = 0; p < kNumGaussianParams; ++p) {
      const std::size_t values = view.count * static_cast<std::size_t>(view.widths[p]);
      st.params[p].assign(view.params[p], view.params[p] + values);
      st.m[p].assign(values, 0.f);
      st.v[p].assign(values, 0.f);
    }
    st.accum = trainer.grad_accum;
    st.count = trainer.grad_count;
    std::mt19937 rng_copy = trainer.rng;  // the seed the trainer's pass draws
    const DensifySettings s =
        train::densifySettings(o.densify_grad_threshold, o.densify_scale_threshold_m, o.prune_min_opacity,
                               o.prune_max_scale_m, static_cast<std::uint32_t>(rng_copy()));
    const std::size_t hits_before = trainer.capacity_hits;
    trainer.densifyAndPrune();
    const DensifyOutcome outcome = gpu_emulator::emulateDensify(st, s, capacity);
    EXPECT_EQ(outcome.capacity_hit, trainer.capacity_hits > hits_before) << "capacity " << capacity;
    EXPECT_GT(outcome.parents.size(), 0u);
    expectSameState(trainer.map, st);
  }
}

// The exposure takes Adam steps with adam_math.h's update (epsilon 1e-8): a step moves each
// parameter against its gradient by about the learning rate.
TEST(TrainingMath, ExposureStepIsAdam) {
  GaussianMapperOptions o;
  o.lr_exposure = 0.01;
  o.num_threads = 1;
  GaussianTrainer trainer(o, ComputeDevice::kCpu);
  TrainingKeyframe kf;
  const float g[6] = {1.f, -2.f, 0.5f, 1e-3f, -1e-3f, 0.f};
  std::copy(g, g + 6, trainer.exposure_grad);
  trainer.stepExposure(kf);
  for (int k = 0; k < 6; ++k) {
    float x = 0.f, m = 0.f, v = 0.f, c1 = 1.f, c2 = 1.f;
    adamBiasCorrections(1, c1, c2);
    adamUpdate(g[k], 0.01f / c1, 1.f / c2, x, m, v, kExposureAdamEpsilon);
    EXPECT_EQ(kf.exposure[k], x) << k;
    if (g[k] != 0.f) {
      EXPECT_NEAR(kf.exposure[k], g[k] > 0.f ? -0.01f : 0.01f, 1e-4f) << k;
    }
  }
  EXPECT_EQ(kf.exposure[5], 0.f);  // no gradient, no step
  EXPECT_EQ(kf.exposure_steps, 1);
}

// least_trained_first: training shares the iterations out evenly over the keyframes it may pick,
// the newest first on a tie, so a keyframe seeded late (mapping was behind) is trained next.
TEST(TrainingSchedule, LeastTrainedFirstSharesIterationsEvenly) {
  GaussianMapperOptions o;
  o.train_downsample = 1;
  o.feature_samples = 0;
  o.num_threads = 1;
  o.densify_interval = 0;
  o.window_size = 2;
  o.global_sample_ratio = 0.5;  // half the picks among all three
  o.least_trained_first = true;
  GaussianTrainer trainer(o, ComputeDevice::kCpu);
  for (int i = 0; i < 3; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 0.05 * i;
    ASSERT_TRUE(trainer.integrate(test::texturedPlaneKeyframe(i, T, 160, 120, 130.0, 10)).added);
  }
  // Every pick takes the least trained of its candidates: keyframes 1 and 2 (in every pick's
  // candidates) never differ by more than one, keyframe 0 (picked only globally, and only when it
  // is strictly behind) never leads them, and the global share keeps it from starving.
  for (int k = 0; k < 30; ++k) ASSERT_GE(trainer.iterate(), 0.0);
  const std::int64_t c0 = trainer.keyframes[0].trained_iterations, c1 = trainer.keyframes[1].trained_iterations,
                     c2 = trainer.keyframes[2].trained_iterations;
  EXPECT_EQ(c0 + c1 + c2, 30);
  EXPECT_LE(std::abs(c1 - c2), 1);
  EXPECT_LE(c0, std::min(c1, c2));
  EXPECT_GE(c0, 5) << "about 15 global picks, most of them keyframe 0's";
  // A keyframe seeded now has no iterations: it is picked next, in the window and globally.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = 0.2;
  ASSERT_TRUE(trainer.integrate(test::texturedPlaneKeyframe(3, T, 160, 120, 130.0, 10)).added);
  ASSERT_GE(trainer.iterate(), 0.0);
  EXPECT_EQ(trainer.keyframes[3].trained_iterations, 1);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

// The isotropy regulariser's gradient against central differences of its value, and none for a
// Gaussian that was not visible.
TEST(TrainingMath, IsotropyGradientMatchesNumericalDifferences) {
  auto value = [](const double* log_scale, double weight) {
    double s[3], mean = 0.0, r = 0.0;
    for (int k = 0; k < 3; ++k) mean += (s[k] = std::exp(log_scale[k])) / 3.0;
    for (int k = 0; k < 3; ++k) r += std::abs(s[k] - mean);
    return weight * r;
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> log_scale(-6.0, -2.0);
  constexpr double kWeight = 0.7, kEps = 1e-5;
  for (int trial = 0; trial < 50; ++trial) {
    double ls[3] = {log_scale(rng), log_scale(rng), log_scale(rng)};
    const float lsf[3] = {static_cast<float>(ls[0]), static_cast<float>(ls[1]), static_cast<float>(ls[2])};
    float grad[3] = {0.f, 0.f, 0.f};
    train::addIsotropyGradient(lsf, 1.f, static_cast<float>(kWeight), grad);
    for (int k = 0; k < 3; ++k) {
      const double keep = ls[k];
      ls[k] = keep + kEps;
      const double plus = value(ls, kWeight);
      ls[k] = keep - kEps;
      const double minus = value(ls, kWeight);
      ls[k] = keep;
      // float evaluation of values ~1e-2: 1e-6 absolute is 1e-4 relative of the typical gradient.
      EXPECT_NEAR(grad[k], (plus - minus) / (2 * kEps), 1e-6) << "trial " << trial << " axis " << k;
    }
  }
  float grad[3] = {0.f, 0.f, 0.f};
  const float needle[3] = {-2.f, -6.f, -6.f};
  train::addIsotropyGradient(needle, 0.f, 1.f, grad);  // not visible
  EXPECT_EQ(grad[0], 0.f);
  train::addIsotropyGradient(needle, 1.f, 1.f, grad);
  EXPECT_GT(grad[0], 0.f);  // gradient descent shrinks the long axis
  EXPECT_LT(grad[1], 0.f);  // and grows the short ones
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
