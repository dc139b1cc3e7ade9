/// The per-tile compositing loops of the rasterizer, forward and backward. This file is compiled
/// twice (dypho_mapping/CMakeLists.txt): with the build's baseline flags into namespace
/// raster::generic, and with -mavx2 -mfma into raster::avx2; DYPHO_RASTER_ISA names the namespace.
/// Everything defined here is inside that namespace or has internal linkage, so the two builds
/// share no symbol; the rasterizer asks the CPU at run time which one to call.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "raster_tile_kernels.h"

#include "dypho/mapping/blend_steps.h"

#ifndef DYPHO_RASTER_ISA
#error "DYPHO_RASTER_ISA (generic or avx2) must be defined when compiling raster_tile_kernels.cpp"
#endif

namespace dypho::mapping::raster::DYPHO_RASTER_ISA {
namespace {

/// Calls copy_row(row offset in the tile, pixel offset in the image, width) for each image row of
/// the tile [tx0, tx1) x [ty0, ty1); a full-width row gets the width as a compile-time constant
/// (fixed-size block copies).
template <typename CopyRow>
void forEachTileRow(int tx0, int ty0, int tx1, int ty1, int image_width, CopyRow&& copy_row) {
  constexpr int S = gs::kTileSize;
  const int w = tx1 - tx0;
  for (int py = ty0; py < ty1; ++py) {
    const int row = (py - ty0) * S;
    const std::size_t o = static_cast<std::size_t>(py) * image_width + tx0;
    if (w == S) {
      copy_row(row, o, std::integral_constant<std::size_t, S>());
    } else {
      copy_row(row, o, static_cast<std::size_t>(w));
    }
  }
}

/// The per-pixel state of one tile in the backward pass (row-major S x S, partial tiles padded).
template <typename T>
struct BackwardTileState {
  /// Transmittance, and colour / depth / alpha accumulated behind the current Gaussian.
  alignas(64) T Tc[gs::kTilePixels], Br[gs::kTilePixels], Bg[gs::kTilePixels], Bb[gs::kTilePixels], BD[gs::kTilePixels],
      BA[gs::kTilePixels];
  /// Loss gradients w.r.t. the pixel's colour, depth and alpha (zero where none is given).
  alignas(64) T gR[gs::kTilePixels], gG[gs::kTilePixels], gB[gs::kTilePixels], gD[gs::kTilePixels], gA[gs::kTilePixels];
  alignas(64) std::uint32_t last[gs::kTilePixels];  ///< one past the last entry the pixel used
};

/// Number of per-lane partial sums of the screen gradient (the fields of gs::ScreenGrad).
constexpr int kNumSums = 10;

/// Loads the tile [tx0, tx1) x [ty0, ty1) of the forward's final transmittance and last entries
/// and of the pixel gradients into `st`; returns the largest last entry of its pixels (>= begin).
template <typename T>
std::uint32_t loadBackwardTile(int tx0, int ty0, int tx1, int ty1, int width, std::size_t npix, std::uint32_t begin,
                               const BackwardInputs<T>& in, BackwardTileState<T>& st) {
  const PixelGrads<T>& grads = in.grads;
  std::uint32_t max_last = begin;
  for (int i = 0; i < gs::kTilePixels; ++i) {
    st.Tc[i] = T(1);
    st.Br[i] = st.Bg[i] = st.Bb[i] = st.BD[i] = st.BA[i] = T(0);
    st.gR[i] = st.gG[i] = st.gB[i] = st.gD[i] = st.gA[i] = T(0);
    st.last[i] = begin;
  }
  // Rows of the images into the tile (block copies; full-width rows with a constant size).
  auto copyRow = [&](int row, std::size_t o, auto width) {
    std::memcpy(&st.Tc[row], &in.final_T[o], width * sizeof(T));
    std::memcpy(&st.last[row], &in.last_entry[o], width * sizeof(std::uint32_t));
    if (grads.color) {
      std::memcpy(&st.gR[row], &grads.color[o], width * sizeof(T));
      std::memcpy(&st.gG[row], &grads.color[npix + o], width * sizeof(T));
      std::memcpy(&st.gB[row], &grads.color[2 * npix + o], width * sizeof(T));
    }
    if (grads.depth) std::memcpy(&st.gD[row], &grads.depth[o], width * sizeof(T));
    if (grads.alpha) std::memcpy(&st.gA[row], &grads.alpha[o], width * sizeof(T));
  };
  forEachTileRow(tx0, ty0, tx1, ty1, width, copyRow);
  for (int i = 0; i < gs::kTilePixels; ++i) max_last = std::max(max_last, st.last[i]);
  return max_last;
}

/// Steps the pixels of rows [py0, py1), 8-pixel blocks [xb0, xb1), back over entry k (Gaussian
/// `p`) and adds each pixel's screen gradient to lane (x - xb) of `lanes` (zeroed here first).
template <typename T>
void backwardGaussianInTile(const PackedGaussian<T>& p, std::uint32_t k, int tx0, int ty0, int py0, int py1, int xb0,
                            int xb1, T min_alpha, BackwardTileState<T>& st, T (&lanes)[kNumSums][8]) {
  constexpr int S = gs::kTileSize;
  const T a = p.conic_a, b = p.conic_b, c = p.conic_c;
  const T mu0 = p.mean_u - T(tx0);
  T* const l_mu = lanes[0];
  T* const l_mv = lanes[1];
  T* const l_a = lanes[2];
  T* const l_b = lanes[3];
  T* const l_c = lanes[4];
  T* const l_o = lanes[5];
  T* const l_c0 = lanes[6];
  T* const l_c1 = lanes[7];
  T* const l_c2 = lanes[8];
  T* const l_d = lanes[9];
  for (int s = 0; s < kNumSums; ++s)
    for (int j = 0; j < 8; ++j) lanes[s][j] = T(0);
  for (int py = py0; py < py1; ++py) {
    const T dy = p.mean_v - T(py);
    const T row_term = gs::conicRowTerm(c, dy);
    const T bdy = b * dy;
    const int row = (py - ty0) * S;
    // Branch-free: a pixel that skips this Gaussian gets alpha = 0, which leaves its
    // transmittance and its accumulators unchanged and contributes nothing.
    for (int xb = xb0; xb < xb1; xb += 8)
#pragma omp simd
      for (int j = 0; j < 8; ++j) {
        const int x = xb + j;
        const int i = row + x;
        const T dx = mu0 - T(x);
        const T power = gs::conicPower(a, bdy, row_term, dx);
        const gs::PixelLossGrad<T> lg{st.gR[i], st.gG[i], st.gB[i], st.gD[i], st.gA[i]};
        gs::BackwardPixel<T> px{st.Tc[i], st.Br[i], st.Bg[i], st.Bb[i], st.BD[i], st.BA[i]};
        const gs::ScreenGrad<T> s =
            gs::blendBackwardStep(p, dx, dy, power, k < st.last[i] ? T(1) : T(0), min_alpha, lg, px);
        st.Tc[i] = px.transmittance;
        st.Br[i] = px.behind_r;
        st.Bg[i] = px.behind_g;
        st.Bb[i] = px.behind_b;
        st.BD[i] = px.behind_depth;
        st.BA[i] = px.behind_alpha;
        l_mu[j] += s.mean_u;
        l_mv[j] += s.mean_v;
        l_a[j] += s.conic_a;
        l_b[j] += s.conic_b;
        l_c[j] += s.conic_c;
        l_o[j] += s.opacity;
        l_c0[j] += s.color[0];
        l_c1[j] += s.color[1];
        l_c2[j] += s.color[2];
        l_d[j] += s.depth;
      }
  }
}

/// Sums each field's 8 lanes (in lane order) and adds the sums to the Gaussian's screen gradient.
template <typename T>
void addLaneSums(const T (&lanes)[kNumSums][8], gs::ScreenGrad<T>& sg) {
  T sums[kNumSums];
  for (int s = 0; s < kNumSums; ++s) {
    T v = T(0);
    for (int j = 0; j < 8; ++j) v += lanes[s][j];
    sums[s] = v;
  }
  sg.mean_u += sums[0];
  sg.mean_v += sums[1];
  sg.conic_a += sums[2];
  sg.conic_b += sums[3];
  sg.conic_c += sums[4];
  sg.opacity += sums[5];
  sg.color[0] += sums[6];
  sg.color[1] += sums[7];
  sg.color[2] += sums[8];
  sg.depth += sums[9];
}

}  // namespace

template <typename T>
void forwardTile(const TileLists<T>& lists, int tile, const ForwardImages<T>& out) {
  constexpr int S = gs::kTileSize;
  const int tx0 = (tile % lists.tiles_x) * S, ty0 = (tile / lists.tiles_x) * S;
  const int tx1 = std::min(tx0 + S, lists.width), ty1 = std::min(ty0 + S, lists.height);
  alignas(64) T Tr[gs::kTilePixels], Cr[gs::kTilePixels], Cg[gs::kTilePixels], Cb[gs::kTilePixels], D[gs::kTilePixels];
  alignas(64) T live[gs::kTilePixels];  // 1 while the pixel still composites, 0 once stopped
  alignas(64) std::uint32_t last[gs::kTilePixels];
  const std::uint32_t begin = lists.ranges[tile], end = lists.ranges[tile + 1];
  const std::uint32_t* const entries = lists.entries;
  const PackedGaussian<T>* const sorted = lists.sorted;
  for (int i = 0; i < gs::kTilePixels; ++i) {
    Tr[i] = T(1);
    Cr[i] = Cg[i] = Cb[i] = D[i] = T(0);
    last[i] = begin;
    // Pixels outside the image (partial tiles) never composite.
    const int px = tx0 + i % S, py = ty0 + i / S;
    live[i] = (px >= tx1 || py >= ty1) ? T(0) : T(1);
  }
  const T min_alpha = lists.min_alpha, min_T = lists.min_transmittance;
  for (std::uint32_t k = begin; k < end; ++k) {
    // The tile's Gaussians are scattered over `sorted` (global depth order): fetch ahead.
    if (k + kPrefetchAhead < end) __builtin_prefetch(&sorted[entries[k + kPrefetchAhead]]);
    const PackedGaussian<T>& p = sorted[entries[k]];
    // Rows of the footprint box inside the tile; every row is processed over the full tile width
    // (fixed trip count, vectorised); pixels outside the box fall below min_alpha by construction.
    const auto [py0, py1, xb0, xb1] = gs::windowInTile(p, tx0, ty0, ty1, S);
    const T a = p.conic_a, b = p.conic_b, c = p.conic_c, o = p.opacity;
    const T c0 = p.color[0], c1 = p.color[1], c2 = p.color[2], dep = p.depth;
    const T mu0 = p.mean_u - T(tx0);
    for (int py = py0; py < py1; ++py) {
      const T dy = p.mean_v - T(py);
      const T row_term = gs::conicRowTerm(c, dy);
      const T bdy = b * dy;
      const int row = (py - ty0) * S;
      for (int xb = xb0; xb < xb1; xb += 8)
#pragma omp simd
        for (int x = xb; x < xb + 8; ++x) {
          const int i = row + x;
          const T dx = mu0 - T(x);
          const T power = gs::conicPower(a, bdy, row_term, dx);
          const gs::ForwardStep<T> step = gs::blendForwardStep(power, o, live[i], min_alpha, min_T, Tr[i]);
          Cr[i] += step.weight * c0;
          Cg[i] += step.weight * c1;
          Cb[i] += step.weight * c2;
          D[i] += step.weight * dep;
          last[i] = step.use > T(0) ? k + 1 : last[i];
          live[i] -= step.stop;
        }
    }
    if (((k - begin) & 31) == 31) {
      T any = T(0);
      for (int i = 0; i < gs::kTilePixels; ++i) any += live[i];
      if (any == T(0)) break;
    }
  }
  // Rows of the tile out to the images (block copies; full-width rows with a constant size).
  alignas(64) T A[gs::kTilePixels];
  for (int i = 0; i < gs::kTilePixels; ++i) A[i] = T(1) - Tr[i];
  const std::size_t npix = static_cast<std::size_t>(lists.width) * lists.height;
  auto copyRow = [&](int row, std::size_t o, auto width) {
    std::memcpy(&out.color[o], &Cr[row], width * sizeof(T));
    std::memcpy(&out.color[npix + o], &Cg[row], width * sizeof(T));
    std::memcpy(&out.color[2 * npix + o], &Cb[row], width * sizeof(T));
    std::memcpy(&out.depth[o], &D[row], width * sizeof(T));
    std::memcpy(&out.alpha[o], &A[row], width * sizeof(T));
    std::memcpy(&out.final_T[o], &Tr[row], width * sizeof(T));
    std::memcpy(&out.last_entry[o], &last[row], width * sizeof(std::uint32_t));
  };
  forEachTileRow(tx0, ty0, tx1, ty1, lists.width, copyRow);
}

template <typename T>
void backwardTile(const TileLists<T>& lists, int tile, const BackwardInputs<T>& in, gs::ScreenGrad<T>* acc) {
  constexpr int S = gs::kTileSize;
  const int tx0 = (tile % lists.tiles_x) * S, ty0 = (tile / lists.tiles_x) * S;
  const int tx1 = std::min(tx0 + S, lists.width), ty1 = std::min(ty0 + S, lists.height);
  const std::size_t npix = static_cast<std::size_t>(lists.width) * lists.height;
  const std::uint32_t* const entries = lists.entries;
  const PackedGaussian<T>* const sorted = lists.sorted;
  BackwardTileState<T> st;
  const std::uint32_t begin = lists.ranges[tile];
  const std::uint32_t max_last = loadBackwardTile(tx0, ty0, tx1, ty1, lists.width, npix, begin, in, st);
  const T min_alpha = lists.min_alpha;
  // Per-lane partial sums of the screen gradients: summed across lanes once per (Gaussian, tile)
  // pair, not once per 8-pixel block.
  alignas(64) T lanes[kNumSums][8];
  for (std::uint32_t k = max_last; k-- > begin;) {
    // Fetch ahead (the list is walked back to front): the Gaussian and its gradient slot.
    if (k >= begin + kPrefetchAhead) {
      const std::uint32_t ahead = entries[k - kPrefetchAhead];
      __builtin_prefetch(&sorted[ahead]);
      __builtin_prefetch(&acc[ahead], 1);
      __builtin_prefetch(reinterpret_cast<const char*>(&acc[ahead] + 1) - 1, 1);
    }
    const std::uint32_t g = entries[k];
    const PackedGaussian<T>& p = sorted[g];
    const auto [py0, py1, xb0, xb1] = gs::windowInTile(p, tx0, ty0, ty1, S);
    if (py0 >= py1 || xb0 >= xb1) continue;
    backwardGaussianInTile(p, k, tx0, ty0, py0, py1, xb0, xb1, min_alpha, st, lanes);
    addLaneSums(lanes, acc[g]);
  }
}

template void forwardTile<float>(const TileLists<float>&, int, const ForwardImages<float>&);
template void forwardTile<double>(const TileLists<double>&, int, const ForwardImages<double>&);
template void backwardTile<float>(const TileLists<float>&, int, const BackwardInputs<float>&, gs::ScreenGrad<float>*);
template void backwardTile<double>(const TileLists<double>&, int, const BackwardInputs<double>&,
                                   gs::ScreenGrad<double>*);

}  // namespace dypho::mapping::raster::DYPHO_RASTER_ISA
