#pragma once
/// \file adam_math.h
/// The Adam update of one value, written once for the CPU optimiser (adam.cpp), the CUDA one and
/// the keyframes' exposure (GaussianTrainer::stepExposure). beta1 = 0.9, beta2 = 0.999, epsilon
/// 1e-15 for the Gaussians (the 3DGS values), 1e-8 for the exposure.

#include <cmath>
#include <cstdint>

#include "dypho/mapping/host_device.h"

namespace dypho::mapping {

constexpr float kAdamBeta1 = 0.9f;
constexpr float kAdamBeta2 = 0.999f;
/// Epsilon of the Gaussians' parameters (3DGS).
constexpr float kAdamEpsilon = 1e-15f;
/// Epsilon of the exposure parameters: their gradients are sums over the image, far from zero.
constexpr float kExposureAdamEpsilon = 1e-8f;

/// The bias corrections of Adam iteration `t` >= 1: 1 - beta1^t and 1 - beta2^t.
inline void adamBiasCorrections(std::int64_t t, float& c1, float& c2) {
  c1 = 1.f - std::pow(kAdamBeta1, static_cast<float>(t));
  c2 = 1.f - std::pow(kAdamBeta2, static_cast<float>(t));
}

/// Step sizes of one Adam iteration t for the five parameter blocks of a GaussianMap (bias
/// corrections included): value -= step * m / (sqrt(v * inv_c2) + eps).
struct AdamStepSizes {
  float step[5] = {0.f, 0.f, 0.f, 0.f, 0.f};  ///< lr_p / (1 - beta1^t); SH block: its DC coefficients
  float step_sh_rest = 0.f;                   ///< lr_sh_rest / (1 - beta1^t): the SH block after the DC
  float inv_c2 = 1.f;                         ///< 1 / (1 - beta2^t)
};

/// One Adam update of one parameter value with gradient `g`: moments m, v updated in place;
/// `step` = lr / (1 - beta1^t), `inv_c2` = 1 / (1 - beta2^t).
DYPHO_HOST_DEVICE inline void adamUpdate(float g, float step, float inv_c2, float& x, float& m, float& v,
                                         float eps = kAdamEpsilon) {
  const float b1 = kAdamBeta1, b2 = kAdamBeta2;
  m = b1 * m + (1.f - b1) * g;
  v = b2 * v + (1.f - b2) * g * g;
  x -= step * m / (std::sqrt(v * inv_c2) + eps);
}

}  // namespace dypho::mapping
