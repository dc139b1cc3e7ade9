#pragma once
/// \file ssim_math.h
/// The per-pixel math of the masked SSIM loss (ssim_loss.h), written once for the CPU (SsimLoss)
/// and the CUDA trainer: the window taps, the SSIM of a pixel from its window statistics with the
/// terms its backward pass needs, and the gradient from the adjoint-filtered terms.

#include <cmath>

#include "dypho/mapping/host_device.h"

namespace dypho::mapping::ssim {

constexpr int kWindow = 11;  ///< taps of the separable Gaussian window
constexpr int kRadius = kWindow / 2;
constexpr double kSigmaPx = 1.5;  ///< its standard deviation [px]
constexpr double kC1 = 0.01 * 0.01;
constexpr double kC2 = 0.03 * 0.03;

/// The normalised window taps (sum 1).
template <typename T>
struct Taps {
  T t[kWindow];
};

template <typename T>
inline Taps<T> windowTaps() {
  double w[kWindow], sum = 0.0;
  for (int k = 0; k < kWindow; ++k) {
    const double d = k - kRadius;
    w[k] = std::exp(-d * d / (2.0 * kSigmaPx * kSigmaPx));
    sum += w[k];
  }
  Taps<T> taps;
  for (int k = 0; k < kWindow; ++k) taps.t[k] = static_cast<T>(w[k] / sum);
  return taps;
}

/// SSIM of one pixel and the derivative terms of the backward pass, from the window means mx,
/// my and raw second moments exx, eyy, exy (w*x^2 ...); `m` is 1 at static pixels, 0 else:
/// p0 = m (dS/dmu_x - 2 mu_x dS/dsxx - mu_y dS/dsxy), p1 = m dS/dsxx, p2 = m dS/dsxy.
template <typename T>
struct PixelSsim {
  T S, p0, p1, p2;
};

template <typename T>
DYPHO_HOST_DEVICE inline PixelSsim<T> pixelSsim(T mx, T my, T exx, T eyy, T exy, T m) {
  const T c1 = static_cast<T>(kC1), c2 = static_cast<T>(kC2);
  const T sxx = exx - mx * mx, syy = eyy - my * my, sxy = exy - mx * my;
  const T a = 2 * mx * my + c1, b = 2 * sxy + c2, cc = mx * mx + my * my + c1, d = sxx + syy + c2;
  const T inv_cd = T(1) / (cc * d);
  PixelSsim<T> r;
  r.S = a * b * inv_cd;
  const T dmx = 2 * my * b * inv_cd - r.S * 2 * mx / cc;
  const T dsxx = -r.S / d;
  const T dsxy = 2 * a * inv_cd;
  r.p0 = m * (dmx - 2 * mx * dsxx - my * dsxy);
  r.p1 = m * dsxx;
  r.p2 = m * dsxy;
  return r;
}

/// d(w (1 - mean SSIM))/dx at a static pixel: scale (G0 + 2 x' G1 + y G2), scale = -w / n, with
/// G the adjoint-filtered p0..p2, x' the composited rendered value and y the target's.
template <typename T>
DYPHO_HOST_DEVICE inline T ssimGradient(T scale, T g0, T g1, T g2, T x, T y) {
  return scale * (g0 + 2 * x * g1 + y * g2);
}

}  // namespace dypho::mapping::ssim
