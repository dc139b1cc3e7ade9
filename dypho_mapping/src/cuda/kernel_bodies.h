#pragma once
/// \file kernel_bodies.h
/// The bodies of the CUDA rasterizer's and trainer's kernels, one call per thread, as host+device
/// functions: the kernels in cuda_rasterizer.cu / cuda_trainer.cu are one-line wrappers around
/// them (the training math itself, loss and densify/prune, is training_math.h's, shared with
/// GaussianTrainer). The tests run the same bodies on the CPU (test/gpu_emulator.h: loops in
/// place of the grid, std::stable_sort in place of the CUB radix sort) against the CPU rasterizer
/// and the CPU trainer, so the indexing, binning and per-pixel logic of the GPU path is tested on
/// machines without a GPU. Only what needs the hardware stays in the kernels: atomics, warp and
/// block reductions, and the lockstep walk of the backward pass.

#include <cstdint>
#include <cstring>

#include "dypho/mapping/adam_math.h"
#include "dypho/mapping/blend_steps.h"
#include "dypho/mapping/cuda_trainer.h"
#include "dypho/mapping/raster_types.h"
#include "dypho/mapping/ssim_math.h"
#include "dypho/mapping/training_math.h"

namespace dypho::mapping::cuda_body {

using Packed = raster::PackedGaussian<float>;
constexpr int S = gs::kTileSize;

/// [begin, end) of a tile's entries in the sorted (tile, depth) pairs; {0, 0} when empty.
struct TileRange {
  std::uint32_t begin, end;
};

/// Cull, project and pack Gaussian i; returns its tile count (0 = not visible; packed[i] is
/// written only when visible).
DYPHO_HOST_DEVICE inline std::uint32_t preprocess(int i, const GaussianParamsView<float>& P,
                                                  const gs::PinholeView<float>& cam, float radius_sigma,
                                                  float min_alpha, int tiles_x, int tiles_y, Packed* packed) {
  const float* pos = P.position + 3 * i;
  const float* ls = P.log_scale + 3 * i;
  if (!gs::mayReachImage(cam, pos[0], pos[1], pos[2], ls[0], ls[1], ls[2], radius_sigma)) return 0;
  const int K3 = 3 * gs::shCoeffCount(P.sh_degree);
  gs::Projected<float> pr;
  if (!gs::projectGaussian(cam, pos, ls, P.rotation + 4 * i, P.opacity_logit[i],
                           P.sh + static_cast<std::size_t>(K3) * i, P.sh_degree, radius_sigma, min_alpha, pr)) {
    return 0;
  }
  Packed p;
  if (!gs::packProjected(pr, cam.width, cam.height, tiles_x, tiles_y, p)) return 0;
  packed[i] = p;
  return static_cast<std::uint32_t>((p.tile_x1 - p.tile_x0) * (p.tile_y1 - p.tile_y0));
}

/// Sort key of a tile entry: tile index in the high 32 bits, the depth's IEEE bits in the low 32
/// (depth > kNearPlaneM > 0, so the bits order like the values: the CPU path's depth key).
DYPHO_HOST_DEVICE inline unsigned long long tileKey(int tile, float depth) {
  std::uint32_t bits;
  std::memcpy(&bits, &depth, sizeof(bits));
  return (static_cast<unsigned long long>(tile) << 32) | bits;
}

/// Writes Gaussian i's (key, index) pairs, one per tile it touches, from its exclusive offset
/// (the inclusive scan of the tile counts minus its own count).
DYPHO_HOST_DEVICE inline void emitKeys(int i, const Packed* packed, const std::uint32_t* tiles_touched,
                                       const std::uint32_t* offsets_inclusive, int tiles_x, unsigned long long* keys,
                                       std::uint32_t* values) {
  const std::uint32_t count = tiles_touched[i];
  if (count == 0) return;
  std::uint32_t o = offsets_inclusive[i] - count;
  const Packed& p = packed[i];
  for (int ty = p.tile_y0; ty < p.tile_y1; ++ty) {
    for (int tx = p.tile_x0; tx < p.tile_x1; ++tx) {
      keys[o] = tileKey(ty * tiles_x + tx, static_cast<float>(p.depth));
      values[o] = static_cast<std::uint32_t>(i);
      ++o;
    }
  }
}

/// Entry k of the sorted keys marks where its tile's range begins or ends.
DYPHO_HOST_DEVICE inline void tileRange(std::uint32_t k, std::uint32_t total, const unsigned long long* keys,
                                        TileRange* ranges) {
  const std::uint32_t tile = static_cast<std::uint32_t>(keys[k] >> 32);
  if (k == 0 || static_cast<std::uint32_t>(keys[k - 1] >> 32) != tile) ranges[tile].begin = k;
  if (k + 1 == total || static_cast<std::uint32_t>(keys[k + 1] >> 32) != tile) ranges[tile].end = k + 1;
}

/// Tile (bx, by) of the image and its pixel (lx, ly).
struct TilePixel {
  int tx0, ty0, ty1;  ///< tile origin, end row
  int lx, px, py;     ///< column in the tile, image pixel
  bool inside;        ///< inside the image (partial tiles)
};

DYPHO_HOST_DEVICE inline TilePixel tilePixel(int bx, int by, int lx, int ly, int width, int height) {
  TilePixel t;
  t.tx0 = bx * S;
  t.ty0 = by * S;
  t.ty1 = t.ty0 + S < height ? t.ty0 + S : height;
  t.lx = lx;
  t.px = t.tx0 + lx;
  t.py = t.ty0 + ly;
  t.inside = t.px < width && t.py < height;
  return t;
}

/// Power of Gaussian p at the pixel, computed as the CPU tile kernels do; false when the pixel
/// lies outside the Gaussian's window in the tile (the CPU path does not visit it either).
DYPHO_HOST_DEVICE inline bool pixelPower(const Packed& p, const TilePixel& t, float& dx, float& dy, float& power) {
  const gs::TileWindow w = gs::windowInTile(p, t.tx0, t.ty0, t.ty1, S);
  if (t.py < w.y0 || t.py >= w.y1 || t.lx < w.xb0 || t.lx >= w.xb1) return false;
  dy = p.mean_v - static_cast<float>(t.py);
  const float row_term = gs::conicRowTerm(p.conic_c, dy);
  const float bdy = p.conic_b * dy;
  dx = (p.mean_u - static_cast<float>(t.tx0)) - static_cast<float>(t.lx);
  power = gs::conicPower(p.conic_a, bdy, row_term, dx);
  return true;
}

/// Images of the forward pass (planar, row-major).
struct ForwardOut {
  float* color;
  float* depth;
  float* alpha;
  float* final_T;
  std::uint32_t* last_entry;
};

/// Front-to-back compositing of one pixel over its tile's list.
DYPHO_HOST_DEVICE inline void forwardPixel(const TilePixel& t, int width, int height, TileRange range,
                                           const std::uint32_t* values, const Packed* packed, float min_alpha,
                                           float min_transmittance, const ForwardOut& out) {
  float Tr = 1.f, c0 = 0.f, c1 = 0.f, c2 = 0.f, d = 0.f;
  float live = t.inside ? 1.f : 0.f;
  std::uint32_t last = range.begin;
  for (std::uint32_t k = range.begin; k < range.end && live > 0.f; ++k) {
    const Packed& p = packed[values[k]];
    float dx, dy, power;
    if (!pixelPower(p, t, dx, dy, power)) continue;
    const gs::ForwardStep<float> step = gs::blendForwardStep(power, p.opacity, live, min_alpha, min_transmittance, Tr);
    c0 += step.weight * p.color[0];
    c1 += step.weight * p.color[1];
    c2 += step.weight * p.color[2];
    d += step.weight * p.depth;
    last = step.use > 0.f ? k + 1 : last;
    live -= step.stop;
  }
  if (!t.inside) return;
  const std::size_t npix = static_cast<std::size_t>(width) * height;
  const std::size_t i = static_cast<std::size_t>(t.py) * width + t.px;
  out.color[i] = c0;
  out.color[npix + i] = c1;
  out.color[2 * npix + i] = c2;
  out.depth[i] = d;
  out.alpha[i] = 1.f - Tr;
  out.final_T[i] = Tr;
  out.last_entry[i] = last;
}

/// A pixel's state at the start of the backward pass: final transmittance, last entry and loss
/// gradients (zeros outside the image; null gradient images = zero).
struct BackwardStart {
  gs::BackwardPixel<float> state;
  gs::PixelLossGrad<float> grad;
  std::uint32_t last;
};

DYPHO_HOST_DEVICE inline BackwardStart backwardStart(const TilePixel& t, int width, int height, TileRange range,
                                                     const float* final_T, const std::uint32_t* last_entry,
                                                     const float* grad_color, const float* grad_depth,
                                                     const float* grad_alpha) {
  BackwardStart b{{1.f, 0.f, 0.f, 0.f, 0.f, 0.f}, {0.f, 0.f, 0.f, 0.f, 0.f}, range.begin};
  if (!t.inside) return b;
  const std::size_t npix = static_cast<std::size_t>(width) * height;
  const std::size_t i = static_cast<std::size_t>(t.py) * width + t.px;
  b.state.transmittance = final_T[i];
  b.last = last_entry[i];
  if (grad_color != nullptr) {
    b.grad.r = grad_color[i];
    b.grad.g = grad_color[npix + i];
    b.grad.b = grad_color[2 * npix + i];
  }
  if (grad_depth != nullptr) b.grad.depth = grad_depth[i];
  if (grad_alpha != nullptr) b.grad.alpha = grad_alpha[i];
  return b;
}

/// Entry k of the tile's list at one pixel, back to front: the pixel's contribution to that
/// Gaussian's screen gradient (false when the pixel does not see it: nothing to add).
DYPHO_HOST_DEVICE inline bool backwardPixelStep(const TilePixel& t, std::uint32_t k, const Packed& p, float min_alpha,
                                                BackwardStart& b, gs::ScreenGrad<float>& contribution) {
  float dx, dy, power;
  if (!t.inside || !pixelPower(p, t, dx, dy, power)) return false;
  contribution = gs::blendBackwardStep(p, dx, dy, power, k < b.last ? 1.f : 0.f, min_alpha, b.grad, b.state);
  return true;
}

/// Parameter gradients of one Gaussian.
struct ParamGradsOut {
  float* position;
  float* log_scale;
  float* rotation;
  float* opacity_logit;
  float* sh;
  float* mean2d_norm;
};

/// Chain rule of Gaussian i from its summed screen gradient (rows of zeros without one);
/// `pose` receives its pose-gradient contribution (zeros without one).
DYPHO_HOST_DEVICE inline void chain(int i, const GaussianParamsView<float>& P, const gs::PinholeView<float>& cam,
                                    bool visible, const gs::ScreenGrad<float>& sg, const ParamGradsOut& out,
                                    float pose[6]) {
  const int K3 = 3 * gs::shCoeffCount(P.sh_degree);
  const std::size_t sh0 = static_cast<std::size_t>(K3) * i;
  for (int k = 0; k < 6; ++k) pose[k] = 0.f;
  if (!visible || gs::isZero(sg)) {
    for (int k = 0; k < 3; ++k) out.position[3 * i + k] = out.log_scale[3 * i + k] = 0.f;
    for (int k = 0; k < 4; ++k) out.rotation[4 * i + k] = 0.f;
    out.opacity_logit[i] = 0.f;
    for (int k = 0; k < K3; ++k) out.sh[sh0 + k] = 0.f;
    out.mean2d_norm[i] = 0.f;
    return;
  }
  gs::ParamGrad<float> pg;
  gs::projectGaussianBackward(cam, P.position + 3 * i, P.log_scale + 3 * i, P.rotation + 4 * i, P.opacity_logit[i],
                              P.sh + sh0, P.sh_degree, sg, pg);
  for (int k = 0; k < 3; ++k) {
    out.position[3 * i + k] = pg.pos[k];
    out.log_scale[3 * i + k] = pg.log_scale[k];
  }
  for (int k = 0; k < 4; ++k) out.rotation[4 * i + k] = pg.quat[k];
  out.opacity_logit[i] = pg.opacity_logit;
  for (int k = 0; k < K3; ++k) out.sh[sh0 + k] = pg.sh[k];
  out.mean2d_norm[i] = std::sqrt(sg.mean_u * sg.mean_u + sg.mean_v * sg.mean_v);
  for (int k = 0; k < 6; ++k) pose[k] = pg.pose[k];
}

// ---------------------------------------------------------------------------------------------
// The SSIM term on the device (SsimLoss's passes, ssim_math.h's per-pixel math), over the planes
// [3, H, W]: (c, v, u) is channel, row, column.

/// The images the SSIM term compares: x' = static ? shown : target, y = target.
struct SsimImages {
  const float* shown;        ///< [3, H, W] the colour the loss compares
  const float* target;       ///< [3, H, W]
  const std::uint8_t* mask;  ///< [H, W] non-zero = static
  int width, height;
};

DYPHO_HOST_DEVICE inline void ssimXY(const SsimImages& im, int c, int v, int u, float& x, float& y) {
  const std::size_t npix = static_cast<std::size_t>(im.width) * im.height;
  const std::size_t i = c * npix + static_cast<std::size_t>(v) * im.width + u;
  y = im.target[i];
  x = im.mask[static_cast<std::size_t>(v) * im.width + u] != 0 ? im.shown[i] : y;
}

/// Horizontal window pass at (c, v, u) of x', y, x'^2, y^2, x'y (zero outside the image).
DYPHO_HOST_DEVICE inline void ssimHorizontal(const SsimImages& im, const ssim::Taps<float>& taps, int c, int v, int u,
                                             float out[5]) {
  for (int j = 0; j < 5; ++j) out[j] = 0.f;
  for (int k = 0; k < ssim::kWindow; ++k) {
    const int uu = u + k - ssim::kRadius;
    if (uu < 0 || uu >= im.width) continue;
    float x, y;
    ssimXY(im, c, v, uu, x, y);
    const float t = taps.t[k];
    out[0] += t * x;
    out[1] += t * y;
    out[2] += t * (x * x);
    out[3] += t * (y * y);
    out[4] += t * (x * y);
  }
}

/// Horizontal window pass of one plane set at (c, v, u) (zero outside the image).
DYPHO_HOST_DEVICE inline float horizontalAt(const float* planes, const ssim::Taps<float>& taps, int c, int v, int u,
                                            int width, int height) {
  const std::size_t row = c * static_cast<std::size_t>(width) * height + static_cast<std::size_t>(v) * width;
  float acc = 0.f;
  for (int k = 0; k < ssim::kWindow; ++k) {
    const int uu = u + k - ssim::kRadius;
    if (uu >= 0 && uu < width) acc += taps.t[k] * planes[row + uu];
  }
  return acc;
}

/// Vertical window pass of one plane set at (c, v, u) (rows outside the image left out).
DYPHO_HOST_DEVICE inline float verticalAt(const float* planes, const ssim::Taps<float>& taps, int c, int v, int u,
                                          int width, int height) {
  const std::size_t plane = c * static_cast<std::size_t>(width) * height;
  const int k0 = ssim::kRadius - v > 0 ? ssim::kRadius - v : 0;
  const int k1 = height - v + ssim::kRadius < ssim::kWindow ? height - v + ssim::kRadius : ssim::kWindow;
  float acc = 0.f;
  for (int k = k0; k < k1; ++k)
    acc += taps.t[k] * planes[plane + static_cast<std::size_t>(v + k - ssim::kRadius) * width + u];
  return acc;
}

/// Adam on value i of a parameter block of rows of `width` (SH block: DC first, then the rest).
DYPHO_HOST_DEVICE inline void adam(std::size_t i, int width, bool is_sh, const AdamStepSizes& s, int block,
                                   const float* grad, float* x, float* m, float* v) {
  const float step = (is_sh && static_cast<int>(i % width) >= 3) ? s.step_sh_rest : s.step[block];
  adamUpdate(grad[i], step, s.inv_c2, x[i], m[i], v[i]);
}

/// The isotropy regulariser's gradient of Gaussian i added to its log-scale gradient.
DYPHO_HOST_DEVICE inline void isotropy(std::size_t i, const float* log_scale, const float* norm, float weight,
                                       float* grad_log_scale) {
  train::addIsotropyGradient(log_scale + 3 * i, norm[i], weight, grad_log_scale + 3 * i);
}

/// Densification statistics of Gaussian i.
DYPHO_HOST_DEVICE inline void statistics(std::size_t i, const float* norm, float* accum, int* count) {
  if (!(norm[i] > 0.f)) return;
  accum[i] += norm[i];
  count[i] += 1;
}

// ---------------------------------------------------------------------------------------------
// Densify and prune on the device (GaussianTrainer::densifyAndPrune's rules): Gaussians whose mean
// screen-space gradient reaches the threshold are cloned (small) or split in two (large); then
// transparent, too large or non-finite ones are removed, and the split parents. New rows are
// appended in parent order, so a capacity limit cuts them exactly where the host loop stops.

/// The training state's blocks on one side (parameters and Adam moments; widths per block).
struct StateBlocks {
  float* params[5];
  float* m[5];
  float* v[5];
  int widths[5];
};

using mapping::DensifySettings;

/// Children of Gaussian i (train::densifyChildren).
DYPHO_HOST_DEVICE inline std::uint32_t densifyChildren(std::size_t i, const float* accum, const int* count,
                                                       const float* log_scale, const DensifySettings& s) {
  return train::densifyChildren(accum[i], count[i], log_scale + 3 * i, s);
}

/// Writes child k of Gaussian i into row `row`: a copy with zero moments; a split child is
/// moved and shrunk by train::splitChild.
DYPHO_HOST_DEVICE inline void spawnChild(std::size_t i, std::uint32_t k, bool split, std::size_t row,
                                         const StateBlocks& b, std::uint32_t seed) {
  for (int p = 0; p < 5; ++p) {
    const int w = b.widths[p];
    for (int c = 0; c < w; ++c) {
      b.params[p][row * w + c] = b.params[p][i * w + c];
      b.m[p][row * w + c] = 0.f;
      b.v[p][row * w + c] = 0.f;
    }
  }
  if (!split) return;
  train::splitChild(seed, static_cast<std::uint32_t>(i), k, b.params[1] + 3 * i, b.params[2] + 4 * i,
                    b.params[0] + row * 3, b.params[1] + row * 3);
}

/// True when row r is to be removed: a split parent whose both halves fit (`split_done`), or
/// pruned (train::isPruned).
DYPHO_HOST_DEVICE inline bool pruned(std::size_t r, bool split_done, const StateBlocks& b, const DensifySettings& s) {
  return split_done || train::isPruned(b.params[1] + 3 * r, b.params[3][r], b.params[0][3 * r], s);
}

/// Copies kept row r to its place `dst_row` in the compacted blocks.
DYPHO_HOST_DEVICE inline void moveRow(std::size_t r, std::size_t dst_row, const StateBlocks& src,
                                      const StateBlocks& dst) {
  for (int p = 0; p < 5; ++p) {
    const int w = src.widths[p];
    for (int c = 0; c < w; ++c) {
      dst.params[p][dst_row * w + c] = src.params[p][r * w + c];
      dst.m[p][dst_row * w + c] = src.m[p][r * w + c];
      dst.v[p][dst_row * w + c] = src.v[p][r * w + c];
    }
  }
}

}  // namespace dypho::mapping::cuda_body
