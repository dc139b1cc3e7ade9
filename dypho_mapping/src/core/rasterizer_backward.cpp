/// Rasterizer: the backward pass (per-tile back-to-front, then per-Gaussian chain rule).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "dypho/mapping/rasterizer.h"

namespace dypho::mapping {

template <typename T>
void Rasterizer<T>::backwardTile(int tile, int thread, const PixelGrads<T>& grads) {
  constexpr int S = gs::kTileSize;
  const int tx0 = (tile % tiles_x_) * S, ty0 = (tile / tiles_x_) * S;
  const int tx1 = std::min(tx0 + S, view_.width), ty1 = std::min(ty0 + S, view_.height);
  const std::size_t npix = static_cast<std::size_t>(view_.width) * view_.height;
  alignas(64) T Tc[gs::kTilePixels], Br[gs::kTilePixels], Bg[gs::kTilePixels], Bb[gs::kTilePixels],
      BD[gs::kTilePixels], BA[gs::kTilePixels];
  alignas(64) T gR[gs::kTilePixels], gG[gs::kTilePixels], gB[gs::kTilePixels], gD[gs::kTilePixels], gA[gs::kTilePixels];
  alignas(64) std::uint32_t last[gs::kTilePixels];
  const std::uint32_t begin = tile_ranges_[tile];
  std::uint32_t max_last = begin;
  for (int i = 0; i < gs::kTilePixels; ++i) {
    Tc[i] = T(1);
    Br[i] = Bg[i] = Bb[i] = BD[i] = BA[i] = T(0);
    gR[i] = gG[i] = gB[i] = gD[i] = gA[i] = T(0);
    last[i] = begin;
  }
  // Rows of the images into the tile (block copies; full-width rows with a constant size).
  const int w = tx1 - tx0;
  auto copyRow = [&](int row, std::size_t o, auto width) {
    std::memcpy(&Tc[row], &final_T_[o], width * sizeof(T));
    std::memcpy(&last[row], &last_entry_[o], width * sizeof(std::uint32_t));
    if (grads.color) {
      std::memcpy(&gR[row], &grads.color[o], width * sizeof(T));
      std::memcpy(&gG[row], &grads.color[npix + o], width * sizeof(T));
      std::memcpy(&gB[row], &grads.color[2 * npix + o], width * sizeof(T));
    }
    if (grads.depth) std::memcpy(&gD[row], &grads.depth[o], width * sizeof(T));
    if (grads.alpha) std::memcpy(&gA[row], &grads.alpha[o], width * sizeof(T));
  };
  for (int py = ty0; py < ty1; ++py) {
    const int row = (py - ty0) * S;
    const std::size_t o = static_cast<std::size_t>(py) * view_.width + tx0;
    if (w == S) {
      copyRow(row, o, std::integral_constant<std::size_t, S>());
    } else {
      copyRow(row, o, static_cast<std::size_t>(w));
    }
  }
  for (int i = 0; i < gs::kTilePixels; ++i) max_last = std::max(max_last, last[i]);
  const T min_alpha = T(settings_.min_alpha), max_alpha = T(gs::kMaxAlpha);
  auto& acc = thread_grads_[thread];
  // Per-lane partial sums of the screen gradients: summed across lanes once per (Gaussian, tile)
  // pair, not once per 8-pixel block.
  constexpr int kNumSums = 10;
  alignas(64) T lanes[kNumSums][8];
  for (std::uint32_t k = max_last; k-- > begin;) {
    // Fetch ahead (the list is walked back to front): the Gaussian and its gradient slot.
    if (k >= begin + kPrefetchAhead) {
      const std::uint32_t ahead = entries_[k - kPrefetchAhead];
      __builtin_prefetch(&sorted_[ahead]);
      __builtin_prefetch(&acc[ahead], 1);
      __builtin_prefetch(reinterpret_cast<const char*>(&acc[ahead] + 1) - 1, 1);
    }
    const std::uint32_t g = entries_[k];
    const Packed& p = sorted_[g];
    const auto [py0, py1, xb0, xb1] = p.windowInTile(tx0, ty0, ty1, S);
    const T a = p.conic_a, b = p.conic_b, c = p.conic_c, o = p.opacity;
    const T c0 = p.color[0], c1 = p.color[1], c2 = p.color[2], dep = p.depth;
    const T mu0 = p.mean_u - T(tx0);
    if (py0 >= py1 || xb0 >= xb1) continue;
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
      const T row_term = T(-0.5) * c * dy * dy;
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
        const T power = T(-0.5) * a * dx * dx - bdy * dx + row_term;
        const T G = gs::blendExp(power);
        const T raw = o * G;
        const T clamped = raw < max_alpha ? raw : max_alpha;
        const T use = (k < last[i] ? T(1) : T(0)) * (power <= T(0) ? T(1) : T(0)) * (clamped >= min_alpha ? T(1) : T(0));
        const T alpha = use * clamped;
        const T Ti = Tc[i] / (T(1) - alpha);
        Tc[i] = Ti;
        const T w = alpha * Ti;
        l_c0[j] += w * gR[i];
        l_c1[j] += w * gG[i];
        l_c2[j] += w * gB[i];
        l_d[j] += w * gD[i];
        const T dL_dalpha = use * Ti * ((c0 - Br[i]) * gR[i] + (c1 - Bg[i]) * gG[i] + (c2 - Bb[i]) * gB[i] +
                                         (dep - BD[i]) * gD[i] + (T(1) - BA[i]) * gA[i]);
        Br[i] = alpha * c0 + (T(1) - alpha) * Br[i];
        Bg[i] = alpha * c1 + (T(1) - alpha) * Bg[i];
        Bb[i] = alpha * c2 + (T(1) - alpha) * Bb[i];
        BD[i] = alpha * dep + (T(1) - alpha) * BD[i];
        BA[i] = alpha + (T(1) - alpha) * BA[i];
        const T dG = (raw < max_alpha ? T(1) : T(0)) * dL_dalpha;  // clamped alpha: no gradient through G, o
        l_o[j] += G * dG;
        const T dpow = o * G * dG;
        l_mu[j] += dpow * (-a * dx - b * dy);
        l_mv[j] += dpow * (-b * dx - c * dy);
        l_a[j] += T(-0.5) * dx * dx * dpow;
        l_b[j] += -dx * dy * dpow;
        l_c[j] += T(-0.5) * dy * dy * dpow;
      }
    }
    T sums[kNumSums];
    for (int s = 0; s < kNumSums; ++s) {
      T v = T(0);
      for (int j = 0; j < 8; ++j) v += lanes[s][j];
      sums[s] = v;
    }
    const T s_mu = sums[0], s_mv = sums[1], s_a = sums[2], s_b = sums[3], s_c = sums[4], s_o = sums[5],
            s_c0 = sums[6], s_c1 = sums[7], s_c2 = sums[8], s_d = sums[9];
    gs::ScreenGrad<T>& sg = acc[g];
    sg.mean_u += s_mu;
    sg.mean_v += s_mv;
    sg.conic_a += s_a;
    sg.conic_b += s_b;
    sg.conic_c += s_c;
    sg.opacity += s_o;
    sg.color[0] += s_c0;
    sg.color[1] += s_c1;
    sg.color[2] += s_c2;
    sg.depth += s_d;
  }
}

template <typename T>
void Rasterizer<T>::backward(const PixelGrads<T>& grads, GaussianGrads<T>& out) {
  const int n = params_.count;
  const int threads = pool_->numThreads();
  thread_grads_.resize(threads);
  thread_pose_.resize(threads);
  const gs::ScreenGrad<T> zero{};
  for (int t = 0; t < threads; ++t) {
    thread_grads_[t].assign(num_visible_, zero);
    thread_pose_[t].assign(6, T(0));
  }
  const auto t0 = std::chrono::steady_clock::now();
  // Fixed tile-to-thread assignment: the per-thread sums, and so training, are repeatable.
  pool_->parallelForStatic(tiles_x_ * tiles_y_, [&](int tile, int thread) { backwardTile(tile, thread, grads); });
  const auto t1 = std::chrono::steady_clock::now();

  // Chain rule per Gaussian, in parameter order (sequential reads of the parameters and writes
  // of the outputs; every output row is written, zeros for Gaussians without a gradient).
  const int K3 = 3 * gs::shCoeffCount(params_.sh_degree);
  out.position.resize(3 * n);
  out.log_scale.resize(3 * n);
  out.rotation.resize(4 * n);
  out.opacity_logit.resize(n);
  out.sh.resize(static_cast<std::size_t>(K3) * n);
  out.mean2d_norm.resize(n);
  const int block = 1024;
  pool_->parallelForStatic((n + block - 1) / block, [&](int bi, int thread) {
    const int begin = bi * block, end = std::min(n, (bi + 1) * block);
    T* pose = thread_pose_[thread].data();
    // Zeros first (block fills), then the Gaussians with a gradient overwrite their rows.
    std::fill(out.position.begin() + 3 * begin, out.position.begin() + 3 * end, T(0));
    std::fill(out.log_scale.begin() + 3 * begin, out.log_scale.begin() + 3 * end, T(0));
    std::fill(out.rotation.begin() + 4 * begin, out.rotation.begin() + 4 * end, T(0));
    std::fill(out.opacity_logit.begin() + begin, out.opacity_logit.begin() + end, T(0));
    std::fill(out.sh.begin() + static_cast<std::size_t>(K3) * begin, out.sh.begin() + static_cast<std::size_t>(K3) * end, T(0));
    std::fill(out.mean2d_norm.begin() + begin, out.mean2d_norm.begin() + end, T(0));
    for (int i = begin; i < end; ++i) {
      // The per-thread sums sit in depth order, i.e. scattered: fetch ahead.
      if (i + static_cast<int>(kPrefetchAhead) < end) {
        const std::uint32_t ahead = rank_[i + kPrefetchAhead];
        if (ahead != kNotVisible) {
          for (int t = 0; t < threads; ++t) __builtin_prefetch(&thread_grads_[t][ahead]);
        }
      }
      const std::uint32_t j = rank_[i];
      if (j == kNotVisible) continue;
      gs::ScreenGrad<T> sg{};
      {
        sg = thread_grads_[0][j];
        for (int t = 1; t < threads; ++t) {
          const gs::ScreenGrad<T>& s = thread_grads_[t][j];
          sg.mean_u += s.mean_u; sg.mean_v += s.mean_v;
          sg.conic_a += s.conic_a; sg.conic_b += s.conic_b; sg.conic_c += s.conic_c;
          sg.opacity += s.opacity; sg.depth += s.depth;
          for (int ch = 0; ch < 3; ++ch) sg.color[ch] += s.color[ch];
        }
      }
      // Not visible, or touched no pixel with a gradient (occluded, or where the loss is flat):
      // every gradient is zero, as filled above.
      if (sg.mean_u == T(0) && sg.mean_v == T(0) && sg.conic_a == T(0) && sg.conic_b == T(0) &&
          sg.conic_c == T(0) && sg.opacity == T(0) && sg.depth == T(0) && sg.color[0] == T(0) &&
          sg.color[1] == T(0) && sg.color[2] == T(0)) {
        continue;
      }
      out.mean2d_norm[i] = std::sqrt(sg.mean_u * sg.mean_u + sg.mean_v * sg.mean_v);
      gs::ParamGrad<T> pg;
      gs::projectGaussianBackward(view_, params_.position + 3 * i, params_.log_scale + 3 * i,
                                  params_.rotation + 4 * i, params_.opacity_logit[i], params_.sh + K3 * i,
                                  params_.sh_degree, sg, pg);
      for (int k = 0; k < 3; ++k) {
        out.position[3 * i + k] = pg.pos[k];
        out.log_scale[3 * i + k] = pg.log_scale[k];
      }
      for (int k = 0; k < 4; ++k) out.rotation[4 * i + k] = pg.quat[k];
      out.opacity_logit[i] = pg.opacity_logit;
      for (int k = 0; k < K3; ++k) out.sh[static_cast<std::size_t>(K3) * i + k] = pg.sh[k];
      for (int k = 0; k < 6; ++k) pose[k] += pg.pose[k];
    }
  });
  for (int j = 0; j < 6; ++j) {
    out.pose[j] = T(0);
    for (int t = 0; t < threads; ++t) out.pose[j] += thread_pose_[t][j];
  }
  using Ms = std::chrono::duration<double, std::milli>;
  times_.tiles_back_ms = Ms(t1 - t0).count();
  times_.chain_ms = Ms(std::chrono::steady_clock::now() - t1).count();
}

template void Rasterizer<float>::backward(const PixelGrads<float>&, GaussianGrads<float>&);
template void Rasterizer<double>::backward(const PixelGrads<double>&, GaussianGrads<double>&);
template void Rasterizer<float>::backwardTile(int, int, const PixelGrads<float>&);
template void Rasterizer<double>::backwardTile(int, int, const PixelGrads<double>&);

}  // namespace dypho::mapping
