#pragma once
/// \file mask_internal.h
/// Small helpers shared by the sources of dypho_mask_core (not installed, not part of the API).
/// Defined once here so that the sources can also be compiled as one unit (unity build).

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

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

/// Sorts depths in ascending order, as std::sort does, for values > 0 (finite or +inf; no NaN):
/// their IEEE-754 bit patterns sort as unsigned integers, so a radix sort over the bits (three
/// passes of 11 bits) gives the same order in linear time. The depth-layer steps sort every
/// masked region's depths per frame: as a comparison sort that was the mask thread's largest cost
/// after the flow fit (7 % of its samples live). Short vectors use std::sort.
inline void sortDepths(std::vector<float>& z) {
  constexpr std::size_t kRadixFrom = 256;
  if (z.size() < kRadixFrom) {
    std::sort(z.begin(), z.end());
    return;
  }
  std::vector<std::uint32_t> keys(z.size()), buffer(z.size());
  std::memcpy(keys.data(), z.data(), z.size() * sizeof(float));
  for (int shift = 0; shift < 32; shift += 11) {
    std::array<std::size_t, 2048> count{};
    for (const std::uint32_t k : keys) ++count[(k >> shift) & 2047u];
    std::size_t sum = 0;
    for (std::size_t& c : count) {
      const std::size_t n = c;
      c = sum;
      sum += n;
    }
    for (const std::uint32_t k : keys) buffer[count[(k >> shift) & 2047u]++] = k;
    keys.swap(buffer);
  }
  std::memcpy(z.data(), keys.data(), z.size() * sizeof(float));
}

}  // namespace internal
}  // namespace mask
}  // namespace dypho
