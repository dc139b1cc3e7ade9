#pragma once
/// \file adam.h
/// Adam optimiser over the parameter blocks of a GaussianMap, one learning rate per block (and a
/// separate one for the SH DC coefficients). Moments follow the map through resize()/compact().

#include <array>
#include <cstdint>
#include <vector>

#include "dypho/mapping/adam_math.h"
#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/rasterizer.h"

namespace dypho::mapping {

/// Step sizes per parameter block.
struct AdamLearningRates {
  double position = 5e-4;    ///< [m]
  double log_scale = 5e-3;   ///< [log m]
  double rotation = 1e-3;    ///< quaternion units
  double opacity = 5e-2;     ///< logit units
  double sh_dc = 2.5e-3;     ///< DC SH coefficients
  double sh_rest = 1.25e-4;  ///< higher SH coefficients
};

class Adam {
 public:
  /// beta1 = 0.9, beta2 = 0.999, epsilon = 1e-15 (the 3DGS values).
  explicit Adam(const AdamLearningRates& rates) : rates_(rates) {}

  /// One step: params -= lr * mhat / (sqrt(vhat) + eps), with the bias correction of the global
  /// step count. `grads` must match the map's size (throws std::invalid_argument otherwise).
  void step(GaussianMap& map, const GaussianGrads<float>& grads);

  /// Advances the step count and returns this step's sizes (what step() applies; the CUDA
  /// trainer applies them on the device).
  AdamStepSizes nextStep();

  /// Grows (zero moments for new Gaussians) or shrinks the moments to `map.size()`.
  void resize(const GaussianMap& map);
  /// Removes the rows with remove[i] != 0 (same mask as GaussianMap::removeIf).
  void compact(const GaussianMap& map, const std::vector<std::uint8_t>& remove);
  /// Zeroes the moments of one block (used by opacity reset).
  void resetBlock(int param);

  std::int64_t steps() const { return steps_; }                          ///< steps taken
  const std::vector<float>& firstMoment(int p) const { return m_[p]; }   ///< for tests
  const std::vector<float>& secondMoment(int p) const { return v_[p]; }  ///< for tests
  std::vector<float>& firstMoment(int p) { return m_[p]; }               ///< the CUDA trainer's mirror
  std::vector<float>& secondMoment(int p) { return v_[p]; }              ///< the CUDA trainer's mirror

 private:
  AdamLearningRates rates_;
  std::array<std::vector<float>, kNumGaussianParams> m_, v_;
  std::int64_t steps_ = 0;
};

}  // namespace dypho::mapping
