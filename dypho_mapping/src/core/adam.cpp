#include "dypho/mapping/adam.h"

#include "dypho/mapping/adam_math.h"

#include <cmath>
#include <stdexcept>

namespace dypho::mapping {

void Adam::resize(const GaussianMap& map) {
  for (int p = 0; p < kNumGaussianParams; ++p) {
    m_[p].resize(map.size() * map.width(p), 0.f);
    v_[p].resize(map.size() * map.width(p), 0.f);
  }
}

void Adam::compact(const GaussianMap& map, const std::vector<std::uint8_t>& remove) {
  for (int p = 0; p < kNumGaussianParams; ++p) {
    GaussianMap::compactRows(m_[p], map.width(p), remove);
    GaussianMap::compactRows(v_[p], map.width(p), remove);
  }
}

void Adam::resetBlock(int param) {
  std::fill(m_[param].begin(), m_[param].end(), 0.f);
  std::fill(v_[param].begin(), v_[param].end(), 0.f);
}

AdamStepSizes Adam::nextStep() {
  ++steps_;
  float c1 = 1.f, c2 = 1.f;
  adamBiasCorrections(steps_, c1, c2);
  const double lr[kNumGaussianParams] = {rates_.position, rates_.log_scale, rates_.rotation, rates_.opacity,
                                         rates_.sh_dc};
  AdamStepSizes s;
  static_assert(kNumGaussianParams == 5, "AdamStepSizes holds five blocks");
  for (int p = 0; p < kNumGaussianParams; ++p) s.step[p] = static_cast<float>(lr[p]) / c1;
  s.step_sh_rest = static_cast<float>(rates_.sh_rest) / c1;
  s.inv_c2 = 1.f / c2;
  return s;
}

void Adam::step(GaussianMap& map, const GaussianGrads<float>& grads) {
  const std::size_t n = map.size();
  const std::vector<float>* g[kNumGaussianParams] = {&grads.position, &grads.log_scale, &grads.rotation,
                                                     &grads.opacity_logit, &grads.sh};
  for (int p = 0; p < kNumGaussianParams; ++p) {
    if (g[p]->size() != n * map.width(p)) {
      throw std::invalid_argument("Adam::step: gradient block " + std::to_string(p) + " has " +
                                  std::to_string(g[p]->size()) + " values, expected " +
                                  std::to_string(n * map.width(p)));
    }
  }
  resize(map);
  const AdamStepSizes sizes = nextStep();
  for (int p = 0; p < kNumGaussianParams; ++p) {
    float* x = map.data(p);
    float* m = m_[p].data();
    float* v = v_[p].data();
    const float* gp = g[p]->data();
    const int w = map.width(p);
    const std::size_t total = n * w;
    const float step_main = sizes.step[p];
    const float step_rest = sizes.step_sh_rest;
    const float inv_c2 = sizes.inv_c2;
    for (std::size_t i = 0; i < total; ++i) {
      // SH block: the first 3 values of each row are the DC coefficients.
      const float s = (p == kParamSh && (i % w) >= 3) ? step_rest : step_main;
      adamUpdate(gp[i], s, inv_c2, x[i], m[i], v[i]);
    }
  }
}

}  // namespace dypho::mapping
