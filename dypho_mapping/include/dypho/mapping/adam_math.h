#pragma once
/// \file adam_math.h
/// The Adam update of one value, written once for the CPU optimiser (adam.cpp) and the CUDA one.
/// beta1 = 0.9, beta2 = 0.999, epsilon = 1e-15 (the 3DGS values).

#include <cmath>

#include "dypho/mapping/host_device.h"

namespace dypho::mapping {

/// Step sizes of one Adam iteration t for the five parameter blocks of a GaussianMap (bias
/// corrections included): value -= step * m / (sqrt(v * inv_c2) + eps).
struct AdamStepSizes {
  float step[5] = {0.f, 0.f, 0.f, 0.f, 0.f};  ///< lr_p / (1 - beta1^t); SH block: its DC coefficients
  float step_sh_rest = 0.f;                   ///< lr_sh_rest / (1 - beta1^t): the SH block after the DC
  float inv_c2 = 1.f;                         ///< 1 / (1 - beta2^t)
};

/// One Adam update of one parameter value with gradient `g`: moments m, v updated in place;
/// `step` = lr / (1 - beta1^t), `inv_c2` = 1 / (1 - beta2^t).
DYPHO_HOST_DEVICE inline void adamUpdate(float g, float step, float inv_c2, float& x, float& m, float& v) {
  const float b1 = 0.9f, b2 = 0.999f, eps = 1e-15f;
  m = b1 * m + (1.f - b1) * g;
  v = b2 * v + (1.f - b2) * g * g;
  x -= step * m / (std::sqrt(v * inv_c2) + eps);
}

}  // namespace dypho::mapping
