#pragma once
/// \file blend_steps.h
/// The per-Gaussian and per-pixel steps of the rasterizer, written once as host+device functions:
/// the CPU tile kernels (raster_tile_kernels.cpp, Gaussian-outer / pixel-inner SIMD loops) and the
/// CUDA kernels (src/cuda, pixel per thread) call them, so both paths compute the same numbers in
/// the same order per pixel.
///
/// Branch-free on purpose: decisions are 0/1 factors in the scalar type, which keeps the CPU loops
/// vectorised; a skipped Gaussian (factor 0) leaves the pixel's state unchanged.

#include <cstdint>

#include "dypho/mapping/gaussian_math.h"
#include "dypho/mapping/raster_types.h"

namespace dypho::mapping::gs {

/// Packs a projected Gaussian for the tile kernels: its footprint box must reach the image
/// [-0.5, width - 0.5] x [-0.5, height - 0.5] (else false; also for a NaN centre), and its tile
/// rectangle is the tiles of `tiles_x` x `tiles_y` that the box overlaps. Returns true when that
/// rectangle is non-empty (the Gaussian is visible).
template <typename T>
DYPHO_HOST_DEVICE inline bool packProjected(const Projected<T>& pr, int width, int height, int tiles_x, int tiles_y,
                                            raster::PackedGaussian<T>& p) {
  const T ru = pr.half_u, rv = pr.half_v;
  if (!(pr.mean_u + ru >= T(-0.5)) || !(pr.mean_u - ru <= T(width) - T(0.5)) || !(pr.mean_v + rv >= T(-0.5)) ||
      !(pr.mean_v - rv <= T(height) - T(0.5))) {
    return false;
  }
  p.mean_u = pr.mean_u;
  p.mean_v = pr.mean_v;
  p.conic_a = pr.conic_a;
  p.conic_b = pr.conic_b;
  p.conic_c = pr.conic_c;
  p.opacity = pr.opacity;
  p.color[0] = pr.color[0];
  p.color[1] = pr.color[1];
  p.color[2] = pr.color[2];
  p.depth = pr.depth_m;
  p.half_u = ru;
  p.half_v = rv;
  const int x0 = static_cast<int>(std::floor((pr.mean_u - ru + T(0.5)) / kTileSize));
  const int x1 = static_cast<int>(std::floor((pr.mean_u + ru + T(0.5)) / kTileSize)) + 1;
  const int y0 = static_cast<int>(std::floor((pr.mean_v - rv + T(0.5)) / kTileSize));
  const int y1 = static_cast<int>(std::floor((pr.mean_v + rv + T(0.5)) / kTileSize)) + 1;
  p.tile_x0 = x0 > 0 ? x0 : 0;
  p.tile_x1 = x1 < tiles_x ? x1 : tiles_x;
  p.tile_y0 = y0 > 0 ? y0 : 0;
  p.tile_y1 = y1 < tiles_y ? y1 : tiles_y;
  return p.tile_x1 > p.tile_x0 && p.tile_y1 > p.tile_y0;
}

/// Part of a tile a Gaussian's footprint box touches: pixel rows [y0, y1) and columns in blocks
/// of 8 (one AVX2 vector) [xb0, xb1), relative to the tile's left edge; empty when y0 >= y1 or
/// xb0 >= xb1. The tile starts at pixel (tx0, ty0), is `tile_size` wide and ends before row ty1.
/// Pixels of the window outside the box itself fall below min_alpha by construction.
struct TileWindow {
  int y0, y1, xb0, xb1;
};

template <typename T>
DYPHO_HOST_DEVICE inline TileWindow windowInTile(const raster::PackedGaussian<T>& p, int tx0, int ty0, int ty1,
                                                 int tile_size) {
  TileWindow w;
  const int y0 = static_cast<int>(std::ceil(p.mean_v - p.half_v));
  const int y1 = static_cast<int>(std::floor(p.mean_v + p.half_v)) + 1;
  w.y0 = y0 > ty0 ? y0 : ty0;
  w.y1 = y1 < ty1 ? y1 : ty1;
  const T mu0 = p.mean_u - T(tx0);
  const int x0 = static_cast<int>(std::ceil(mu0 - p.half_u));
  const int x1 = static_cast<int>(std::floor(mu0 + p.half_u)) + 1;
  const int cx0 = x0 > 0 ? x0 : 0;
  const int cx1 = x1 < tile_size ? x1 : tile_size;
  w.xb0 = (cx0 / 8) * 8;
  w.xb1 = cx1 <= cx0 ? w.xb0 : ((cx1 + 7) / 8) * 8;
  return w;
}

/// What one front-to-back step did at a pixel.
template <typename T>
struct ForwardStep {
  T weight;  ///< alpha * T before this Gaussian (0 when skipped): colour and depth add weight * value
  T use;     ///< 1 when the Gaussian was composited
  T stop;    ///< 1 when the pixel stops here (transmittance would fall below the threshold)
};

/// One Gaussian at one pixel, front to back. `power` is conicPower() at the pixel, `live` 1 while
/// the pixel still composites (0 after it stopped, or outside the image). Updates `transmittance`.
template <typename T>
DYPHO_HOST_DEVICE inline ForwardStep<T> blendForwardStep(T power, T opacity, T live, T min_alpha, T min_transmittance,
                                                         T& transmittance) {
  T alpha = opacity * blendExp(power);
  alpha = alpha < T(kMaxAlpha) ? alpha : T(kMaxAlpha);
  const T ok = (power <= T(0) ? T(1) : T(0)) * (alpha >= min_alpha ? T(1) : T(0)) * live;
  const T test_T = transmittance * (T(1) - alpha);
  const T stop = ok * (test_T < min_transmittance ? T(1) : T(0));
  const T use = ok - stop;
  const T weight = use * alpha * transmittance;
  transmittance += use * (test_T - transmittance);
  return {weight, use, stop};
}

/// A pixel during the back-to-front pass: its transmittance in front of the current Gaussian
/// (recovered by division from the final one) and the colour, depth and alpha blended behind it.
template <typename T>
struct BackwardPixel {
  T transmittance;
  T behind_r, behind_g, behind_b, behind_depth, behind_alpha;
};

/// dL/d(rendered colour, depth, alpha) at a pixel.
template <typename T>
struct PixelLossGrad {
  T r, g, b, depth, alpha;
};

/// One Gaussian at one pixel, back to front: updates `px` and returns this pixel's contribution
/// to the Gaussian's screen-space gradient. `in_list` is 1 when the Gaussian was among those the
/// pixel composited in the forward pass (its list position is before the pixel's last entry);
/// dx = mean_u - x, dy = mean_v - y, power = conicPower() at the pixel.
template <typename T>
DYPHO_HOST_DEVICE inline ScreenGrad<T> blendBackwardStep(const raster::PackedGaussian<T>& p, T dx, T dy, T power,
                                                         T in_list, T min_alpha, const PixelLossGrad<T>& g,
                                                         BackwardPixel<T>& px) {
  const T a = p.conic_a, b = p.conic_b, c = p.conic_c, o = p.opacity;
  const T c0 = p.color[0], c1 = p.color[1], c2 = p.color[2], dep = p.depth;
  const T max_alpha = T(kMaxAlpha);
  const T G = blendExp(power);
  const T raw = o * G;
  const T clamped = raw < max_alpha ? raw : max_alpha;
  const T use = in_list * (power <= T(0) ? T(1) : T(0)) * (clamped >= min_alpha ? T(1) : T(0));
  const T alpha = use * clamped;
  const T Ti = px.transmittance / (T(1) - alpha);
  px.transmittance = Ti;
  const T w = alpha * Ti;
  ScreenGrad<T> s;
  s.color[0] = w * g.r;
  s.color[1] = w * g.g;
  s.color[2] = w * g.b;
  s.depth = w * g.depth;
  const T dL_dalpha = use * Ti *
                      ((c0 - px.behind_r) * g.r + (c1 - px.behind_g) * g.g + (c2 - px.behind_b) * g.b +
                       (dep - px.behind_depth) * g.depth + (T(1) - px.behind_alpha) * g.alpha);
  px.behind_r = alpha * c0 + (T(1) - alpha) * px.behind_r;
  px.behind_g = alpha * c1 + (T(1) - alpha) * px.behind_g;
  px.behind_b = alpha * c2 + (T(1) - alpha) * px.behind_b;
  px.behind_depth = alpha * dep + (T(1) - alpha) * px.behind_depth;
  px.behind_alpha = alpha + (T(1) - alpha) * px.behind_alpha;
  const T dG = (raw < max_alpha ? T(1) : T(0)) * dL_dalpha;  // clamped alpha: no gradient through G, o
  s.opacity = G * dG;
  const T dpow = o * G * dG;
  s.mean_u = dpow * (-a * dx - b * dy);
  s.mean_v = dpow * (-b * dx - c * dy);
  s.conic_a = T(-0.5) * dx * dx * dpow;
  s.conic_b = -dx * dy * dpow;
  s.conic_c = T(-0.5) * dy * dy * dpow;
  return s;
}

/// True when every component of a summed screen gradient is zero (the Gaussian touched no pixel
/// with a gradient: all its parameter gradients are zero).
template <typename T>
DYPHO_HOST_DEVICE inline bool isZero(const ScreenGrad<T>& s) {
  return s.mean_u == T(0) && s.mean_v == T(0) && s.conic_a == T(0) && s.conic_b == T(0) && s.conic_c == T(0) &&
         s.opacity == T(0) && s.depth == T(0) && s.color[0] == T(0) && s.color[1] == T(0) && s.color[2] == T(0);
}

}  // namespace dypho::mapping::gs
