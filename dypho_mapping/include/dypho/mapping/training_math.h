#pragma once
/// \file training_math.h
/// The training math of the Gaussian map, written once for the CPU trainer (GaussianTrainer) and
/// the CUDA one (CudaTrainer's kernels call these through kernel_bodies.h):
///  - the masked L1 loss on colour, depth and alpha and its pixel gradients (the paper's
///    L = (1 - lambda) L1(colour) + lambda L1(depth), with the alpha term that pulls opacity to 1
///    where depth is measured), and the per-keyframe exposure exp(k_c) C + b_c with its chain rule;
///  - the densify and prune rules (3DGS): clone a small Gaussian with a large mean screen-space
///    gradient, split a large one into two samples with 1/1.6 of its scale, prune transparent,
///    too large or non-finite ones; the split samples are a function of (seed, Gaussian, child,
///    axis) only, so the CPU loop and the GPU grid draw the same numbers;
///  - the opacity reset value;
///  - the isotropy regulariser of the scales.
/// The loops around them (CPU) and the grids (CUDA) belong to the callers. The Adam update of one
/// value is adam_math.h's.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "dypho/mapping/gaussian_math.h"
#include "dypho/mapping/host_device.h"

namespace dypho::mapping {

/// Settings of one densify-and-prune pass (densifySettings() from the mapper's options).
struct DensifySettings {
  float grad_threshold = 0.f;     ///< mean |dL/dmean2d| at or above which a Gaussian is densified [1/px]
  float log_split_scale = 0.f;    ///< largest log std dev above which it is split, else cloned
  float min_opacity_logit = 0.f;  ///< pruned below this opacity logit
  float max_log_scale = 0.f;      ///< pruned above this largest log std dev
  std::uint32_t seed = 0;         ///< of the split offsets
};

namespace train {

/// A split child has 1/kSplitScaleDivisor of its parent's standard deviations (3DGS: 1.6).
constexpr float kSplitScaleDivisor = 1.6f;
/// The opacity reset caps every opacity at this value (3DGS: 0.01).
constexpr float kOpacityResetValue = 0.01f;

/// The opacity logit log(o / (1 - o)) of opacity `o` in (0, 1).
inline float opacityLogit(float o) { return std::log(o / (1.f - o)); }

/// The settings of a pass from the mapper's options: gradient threshold [1/px], split scale [m],
/// minimum opacity in [0, 1), maximum scale [m], and the seed of this pass's split samples.
inline DensifySettings densifySettings(double grad_threshold, double split_scale_m, double prune_min_opacity,
                                       double prune_max_scale_m, std::uint32_t seed) {
  DensifySettings s;
  s.grad_threshold = static_cast<float>(grad_threshold);
  s.log_split_scale = std::log(static_cast<float>(split_scale_m));
  s.min_opacity_logit = opacityLogit(static_cast<float>(prune_min_opacity));
  s.max_log_scale = std::log(static_cast<float>(prune_max_scale_m));
  s.seed = seed;
  return s;
}

/// Largest of the three log standard deviations of a Gaussian.
DYPHO_HOST_DEVICE inline float maxLogScale(const float* log_scale) {
  const float m = log_scale[0] > log_scale[1] ? log_scale[0] : log_scale[1];
  return m > log_scale[2] ? m : log_scale[2];
}

/// Children of a Gaussian with `grad_accum` summed over `grad_count` visible iterations: 0 none,
/// 1 a clone (small), 2 the halves of a split (large).
DYPHO_HOST_DEVICE inline std::uint32_t densifyChildren(float grad_accum, int grad_count, const float* log_scale,
                                                       const DensifySettings& s) {
  if (grad_count == 0 || grad_accum / static_cast<float>(grad_count) < s.grad_threshold) return 0;
  return maxLogScale(log_scale) <= s.log_split_scale ? 1u : 2u;
}

/// A standard normal sample, a function of (seed, i, k, axis) only (hash, then Box-Muller).
DYPHO_HOST_DEVICE inline float normalSample(std::uint32_t seed, std::uint32_t i, std::uint32_t k, std::uint32_t axis) {
  auto hash = [](std::uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
  };
  const std::uint32_t h1 = hash(seed ^ hash(i * 8u + k * 4u + axis + 0x9e3779b9U));
  const std::uint32_t h2 = hash(h1 ^ 0x85ebca6bU);
  const float u1 = (static_cast<float>(h1 >> 8) + 1.f) * (1.f / 16777217.f);  // (0, 1]
  const float u2 = static_cast<float>(h2 >> 8) * (1.f / 16777216.f);          // [0, 1)
  return std::sqrt(-2.f * std::log(u1)) * std::cos(6.2831853071795865f * u2);
}

/// Child k of a split of Gaussian i (parent log scales and rotation given): its position, a copy
/// of the parent's, moves by R (s . n) (n standard normal), and its scale shrinks by 1.6.
DYPHO_HOST_DEVICE inline void splitChild(std::uint32_t seed, std::uint32_t i, std::uint32_t k,
                                         const float* parent_log_scale, const float* parent_rotation_wxyz,
                                         float* child_position, float* child_log_scale) {
  const gs::Mat3<float> R = gs::quatToRotation(parent_rotation_wxyz);
  float local[3];
  for (int a = 0; a < 3; ++a) {
    local[a] = std::exp(parent_log_scale[a]) * normalSample(seed, i, k, static_cast<std::uint32_t>(a));
  }
  for (int a = 0; a < 3; ++a) {
    child_position[a] += R.m[a][0] * local[0] + R.m[a][1] * local[1] + R.m[a][2] * local[2];
    child_log_scale[a] -= std::log(kSplitScaleDivisor);
  }
}

/// True when a Gaussian is pruned: transparent, too large, or with a non-finite position.
DYPHO_HOST_DEVICE inline bool isPruned(const float* log_scale, float opacity_logit, float position_x,
                                       const DensifySettings& s) {
  const float x = position_x;
  return opacity_logit < s.min_opacity_logit || maxLogScale(log_scale) > s.max_log_scale || !(x == x) ||
         !(x - x == 0.f);
}

/// The isotropy regulariser of one Gaussian (as MonoGS): weight_per_gaussian sum_k |s_k - mean s|
/// over its standard deviations s_k = exp(log_scale_k), which keeps needles and flakes that look
/// right only from the keyframes out of the map. Adds its gradient w.r.t. the log scales to
/// `grad` when the Gaussian was visible in the iteration (`mean2d_norm` > 0).
DYPHO_HOST_DEVICE inline void addIsotropyGradient(const float* log_scale, float mean2d_norm, float weight_per_gaussian,
                                                  float* grad) {
  if (!(mean2d_norm > 0.f)) return;
  float s[3], sign[3];
  float mean = 0.f, sign_sum = 0.f;
  for (int k = 0; k < 3; ++k) {
    s[k] = std::exp(log_scale[k]);
    mean += s[k] * (1.f / 3.f);
  }
  for (int k = 0; k < 3; ++k) {
    sign[k] = s[k] > mean ? 1.f : (s[k] < mean ? -1.f : 0.f);
    sign_sum += sign[k];
  }
  // d/ds_k sum_j |s_j - m| = sign_k - sum_j sign_j / 3; d s_k / d log s_k = s_k.
  for (int k = 0; k < 3; ++k) grad[k] += weight_per_gaussian * s[k] * (sign[k] - sign_sum * (1.f / 3.f));
}

// ---------------------------------------------------------------------------------------------
// The loss.

/// Settings of the masked L1 loss of one keyframe (lossParams()).
struct LossParams {
  int npix;
  float wc, wd, wa;          ///< per-value gradient magnitudes: (1-lambda)/(3 nc), lambda/nd, alpha_weight/nd
  float gain[3], offset[3];  ///< exposure exp(k_c), b_c
  int exposure;              ///< 1 when the exposure is applied
  /// 1 when an SSIM term follows: the colour gradients stay w.r.t. the shown (exposed) colour and
  /// the exposure's chain rule runs after it (exposureChain).
  int defer_exposure;
};

/// Number of sums of the loss: |colour|, |depth|, 1 - alpha, d gain[3], d offset[3].
constexpr int kLossSums = 9;

/// The loss settings for `npix` pixels of which `static_pixels` are static and `depth_pixels` of
/// those have a depth; `exposure` (k_c then b_c; null = none) and whether an SSIM term follows.
inline LossParams lossParams(std::size_t npix, std::size_t static_pixels, std::size_t depth_pixels, double lambda_depth,
                             double alpha_weight, const float* exposure, bool ssim_follows) {
  const double nc = static_cast<double>(static_pixels), nd = static_cast<double>(depth_pixels);
  LossParams L{};
  L.npix = static_cast<int>(npix);
  L.wc = nc > 0 ? static_cast<float>((1.0 - lambda_depth) / (3.0 * nc)) : 0.f;
  L.wd = nd > 0 ? static_cast<float>(lambda_depth / nd) : 0.f;
  L.wa = nd > 0 ? static_cast<float>(alpha_weight / nd) : 0.f;
  L.exposure = exposure != nullptr ? 1 : 0;
  L.defer_exposure = ssim_follows && exposure != nullptr ? 1 : 0;
  for (int ch = 0; ch < 3; ++ch) {
    L.gain[ch] = exposure != nullptr ? std::exp(exposure[ch]) : 1.f;
    L.offset[ch] = exposure != nullptr ? exposure[3 + ch] : 0.f;
  }
  return L;
}

/// The loss from its sums (sums[0..2] of l1LossPixel), without an SSIM term; 0 without static pixels.
template <typename Sum>
inline double lossFromSums(const Sum* sums, std::size_t static_pixels, std::size_t depth_pixels, double lambda_depth,
                           double alpha_weight) {
  const double nc = static_cast<double>(static_pixels), nd = static_cast<double>(depth_pixels);
  if (nc == 0) return 0.0;
  return (1.0 - lambda_depth) * sums[0] / (3.0 * nc) +
         (nd > 0 ? (lambda_depth * sums[1] + alpha_weight * sums[2]) / nd : 0.0);
}

/// Loss terms and pixel gradients of pixel i; adds its sums to `sums` (Sum: double on the CPU,
/// float per GPU thread). With `shown_out` not null, the colour the loss compares
/// (exp(k) C_r + b, or C_r) is written there ([3, H, W], every pixel) for the SSIM term.
/// Images are planar [3, H, W] (colour, RGB in [0, 1]) and [H, W]; target depth 0 = none;
/// mask non-zero = static.
template <typename Sum>
DYPHO_HOST_DEVICE inline void l1LossPixel(int i, const LossParams& L, const float* color, const float* depth,
                                          const float* alpha, const float* t_rgb, const float* t_depth,
                                          const std::uint8_t* mask, float* g_color, float* g_depth, float* g_alpha,
                                          Sum sums[kLossSums], float* shown_out = nullptr) {
  const std::size_t n = static_cast<std::size_t>(L.npix);
  float gd = 0.f, ga = 0.f;
  float gc[3] = {0.f, 0.f, 0.f};
  if (shown_out != nullptr) {
    for (int ch = 0; ch < 3; ++ch) {
      const float rendered = color[ch * n + i];
      shown_out[ch * n + i] = L.exposure ? L.gain[ch] * rendered + L.offset[ch] : rendered;
    }
  }
  if (mask[i] != 0) {
    for (int ch = 0; ch < 3; ++ch) {
      const float rendered = color[ch * n + i];
      const float shown = L.exposure ? L.gain[ch] * rendered + L.offset[ch] : rendered;
      const float diff = shown - t_rgb[ch * n + i];
      sums[0] += diff < 0.f ? -diff : diff;
      float g = diff > 0.f ? L.wc : (diff < 0.f ? -L.wc : 0.f);
      if (L.exposure && !L.defer_exposure) {
        sums[3 + ch] += g * (shown - L.offset[ch]);  // d(exp(k) x + b)/dk = exp(k) x
        sums[6 + ch] += g;
        g *= L.gain[ch];
      }
      gc[ch] = g;
    }
    const float td = t_depth[i];
    if (td > 0.f) {
      const float diff = depth[i] - td;
      sums[1] += diff < 0.f ? -diff : diff;
      gd = diff > 0.f ? L.wd : (diff < 0.f ? -L.wd : 0.f);
      sums[2] += 1.f - alpha[i];  // alpha <= 1: |1 - A| = 1 - A
      ga = -L.wa;
    }
  }
  for (int ch = 0; ch < 3; ++ch) g_color[ch * n + i] = gc[ch];
  g_depth[i] = gd;
  g_alpha[i] = ga;
}

/// The exposure's chain rule at pixel i after every colour term (deferred): dL/dk_c, dL/db_c
/// summed into sums[3..8], and the colour gradient taken back through the gain.
template <typename Sum>
DYPHO_HOST_DEVICE inline void exposureChain(int i, const LossParams& L, const float* shown, float* g_color,
                                            Sum sums[kLossSums]) {
  const std::size_t n = static_cast<std::size_t>(L.npix);
  for (int ch = 0; ch < 3; ++ch) {
    const float g = g_color[ch * n + i];
    sums[3 + ch] += g * (shown[ch * n + i] - L.offset[ch]);
    sums[6 + ch] += g;
    g_color[ch * n + i] = g * L.gain[ch];
  }
}

}  // namespace train
}  // namespace dypho::mapping
