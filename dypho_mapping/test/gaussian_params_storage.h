#pragma once
/// \file gaussian_params_storage.h
/// Test helper: Gaussian parameters in plain vectors (the layout GaussianParamsView reads), for
/// rasterizer tests that build scenes by hand.

#include <vector>

#include "dypho/mapping/rasterizer.h"

namespace dypho::mapping {

template <typename T>
struct GaussianParamsStorage {
  int n = 0;                                ///< number of Gaussians
  int sh_degree = 1;                        ///< SH degree of `sh`
  std::vector<T> pos, scale, rot, opa, sh;  ///< 3, 3 (log), 4 (wxyz), 1 (logit), 3 * (deg+1)^2 each

  GaussianParamsView<T> view() const {
    GaussianParamsView<T> v;
    v.position = pos.data();
    v.log_scale = scale.data();
    v.rotation = rot.data();
    v.opacity_logit = opa.data();
    v.sh = sh.data();
    v.count = n;
    v.sh_degree = sh_degree;
    return v;
  }
};

}  // namespace dypho::mapping
