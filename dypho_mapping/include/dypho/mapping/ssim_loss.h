#pragma once
/// \file ssim_loss.h
/// Structural similarity (SSIM, Wang et al. 2004) of a rendered colour image against the input
/// image, averaged over the static pixels, and its analytic gradient w.r.t. the rendered image
/// (fed to the rasterizer backward pass like the L1 terms).
///
/// Window: separable Gaussian, 11 taps, sigma 1.5 px, normalised to sum 1, zero padding at the
/// image border (as 3D Gaussian Splatting's `ssim()`): per channel
///   mu_x = w*x, sxx = w*x^2 - mu_x^2, sxy = w*(x y) - mu_x mu_y (same for y),
///   SSIM = (2 mu_x mu_y + C1)(2 sxy + C2) / ((mu_x^2 + mu_y^2 + C1)(sxx + syy + C2)),
///   C1 = 0.01^2, C2 = 0.03^2 (intensities in [0, 1]).
/// Mask: the value is the mean of the SSIM map over static pixels and the 3 channels. Dynamic
/// pixels take the target's value in the rendered image before the windows are applied
/// (x' = M x + (1 - M) y), so a window that overlaps a person sees agreement there, and neither
/// the value nor the gradient depends on the rendered colour of a dynamic pixel.
///
/// Cost: 5 separable convolutions forward and 3 backward per channel, parallel over image rows
/// (ThreadPool); scratch buffers only grow (no allocation once the image size is reached).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dypho/mapping/thread_pool.h"

#include "dypho/mapping/ssim_math.h"

namespace dypho::mapping {

/// Masked SSIM with gradient. Templated on the scalar: float in the mapper, double for the
/// gradient checks. Holds scratch buffers; one object per thread of use. Not thread-safe.
template <typename T>
class SsimLoss {
 public:
  static constexpr int kWindow = ssim::kWindow;       ///< taps of the Gaussian window
  static constexpr double kSigmaPx = ssim::kSigmaPx;  ///< its standard deviation [px]
  static constexpr double kC1 = ssim::kC1;
  static constexpr double kC2 = ssim::kC2;

  /// `pool` (not owned, may be null = single-threaded) runs the row loops.
  explicit SsimLoss(ThreadPool* pool);

  /// Mean SSIM over the static pixels of `rendered` vs `target` (both [3, H, W] planar, row-major,
  /// values in [0, ~1]); 1 when no pixel is static. `static_mask`: H rows of `mask_step` bytes,
  /// nonzero = static; null = every pixel static. When `grad` is not null, adds
  /// `weight` * d(1 - mean SSIM)/d rendered to it ([3, H, W]). When `ssim_map` is not null, writes
  /// the per-pixel SSIM there ([3, H, W], also at dynamic pixels).
  double compute(const T* rendered, const T* target, const std::uint8_t* static_mask, std::size_t mask_step, int width,
                 int height, T weight, T* grad, T* ssim_map = nullptr);

  /// The normalised window taps (kWindow values, sum 1).
  const T* window() const { return taps_; }

 private:
  void resize(int width, int height);

  ThreadPool* pool_;
  T taps_[kWindow];
  int width_ = 0, height_ = 0;
  std::vector<T> x_, y_;              ///< [3HW] composited rendered image, target
  std::vector<T> h_[5];               ///< [3HW] horizontal pass (reused by the backward)
  std::vector<T> p_[3];               ///< [3HW] per-pixel dS/d(mu_x, sxx, sxy) terms
  std::vector<std::uint8_t> static_;  ///< [HW] 1 = static
  std::vector<double> row_sum_;       ///< [3H] SSIM summed per row (fixed-order reduction)
  std::vector<std::vector<T>> pad_;   ///< [threads] a zero-padded row
};

extern template class SsimLoss<float>;
extern template class SsimLoss<double>;

}  // namespace dypho::mapping
