#pragma once
/// \file jacobian_check.h
/// Test helper: analytic Jacobians of a ceres::CostFunction against central differences.

#include <vector>

#include <Eigen/Core>
#include <ceres/cost_function.h>
#include <gtest/gtest.h>

namespace dypho {
namespace tracking {
namespace test {

/// Compares every Jacobian block of `cost` at `params` (ambient coordinates) with central
/// differences of step h. Tolerance: |analytic - numeric| <= tol * max(1, |numeric|). With
/// h = 1e-6 the truncation error is O(h^2 * third derivative) ~1e-10 and the rounding error
/// ~eps * |r| / h ~1e-9 for residuals of order 10, so tol = 1e-5 leaves a wide margin while a
/// wrong sign or a missing term (errors of order 1) fails at once.
inline void expectJacobiansMatch(const ceres::CostFunction& cost, std::vector<std::vector<double>> params,
                                 double h = 1e-6, double tol = 1e-5) {
  const int m = cost.num_residuals();
  const auto& sizes = cost.parameter_block_sizes();
  ASSERT_EQ(sizes.size(), params.size());
  std::vector<const double*> ptrs;
  for (auto& p : params) ptrs.push_back(p.data());
  std::vector<std::vector<double>> jac(params.size());
  std::vector<double*> jac_ptrs;
  for (size_t b = 0; b < params.size(); ++b) {
    jac[b].assign(static_cast<size_t>(m * sizes[b]), 0.0);
    jac_ptrs.push_back(jac[b].data());
  }
  std::vector<double> r0(static_cast<size_t>(m));
  ASSERT_TRUE(cost.Evaluate(ptrs.data(), r0.data(), jac_ptrs.data()));
  for (size_t b = 0; b < params.size(); ++b) {
    for (int k = 0; k < sizes[b]; ++k) {
      std::vector<double> rp(static_cast<size_t>(m)), rm(static_cast<size_t>(m));
      const double saved = params[b][static_cast<size_t>(k)];
      params[b][static_cast<size_t>(k)] = saved + h;
      ASSERT_TRUE(cost.Evaluate(ptrs.data(), rp.data(), nullptr));
      params[b][static_cast<size_t>(k)] = saved - h;
      ASSERT_TRUE(cost.Evaluate(ptrs.data(), rm.data(), nullptr));
      params[b][static_cast<size_t>(k)] = saved;
      for (int i = 0; i < m; ++i) {
        const double numeric = (rp[static_cast<size_t>(i)] - rm[static_cast<size_t>(i)]) / (2 * h);
        const double analytic = jac[b][static_cast<size_t>(i * sizes[b] + k)];
        EXPECT_NEAR(analytic, numeric, tol * std::max(1.0, std::abs(numeric)))
            << "block " << b << " param " << k << " residual " << i;
      }
    }
  }
}

}  // namespace test
}  // namespace tracking
}  // namespace dypho
