#pragma once
/// \file mask_internal.h
/// Small helpers shared by the sources of dypho_mask_core (not installed, not part of the API).
/// Defined once here so that the sources can also be compiled as one unit (unity build).

#include <chrono>
#include <cmath>

namespace dypho {
namespace mask {
namespace internal {

using Clock = std::chrono::steady_clock;

/// Wall time since `t0` [ms].
inline double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// A depth sample [m] that holds a value: positive and finite (0 and NaN mean none).
inline bool valid(float z) { return z > 0.f && std::isfinite(z); }

}  // namespace internal
}  // namespace mask
}  // namespace dypho
