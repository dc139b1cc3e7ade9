/// Rasterizer: projection, binning and the forward compositing pass.
#include "dypho/mapping/rasterizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace dypho::mapping {

template <typename T>
gs::PinholeView<T> makePinholeView(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) {
  gs::PinholeView<T> v{};
  v.fx = T(camera.fx);
  v.fy = T(camera.fy);
  v.cx = T(camera.cx);
  v.cy = T(camera.cy);
  v.width = camera.width;
  v.height = camera.height;
  const Eigen::Isometry3d T_cw = T_world_camera.inverse();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) v.R_cw[i][j] = T(T_cw.linear()(i, j));
    v.t_cw[i] = T(T_cw.translation()(i));
    v.center_w[i] = T(T_world_camera.translation()(i));
  }
  return v;
}
template gs::PinholeView<float> makePinholeView<float>(const Eigen::Isometry3d&, const CameraIntrinsics&);
template gs::PinholeView<double> makePinholeView<double>(const Eigen::Isometry3d&, const CameraIntrinsics&);

template <typename T>
Rasterizer<T>::Rasterizer(ThreadPool* pool, const RasterSettings& settings) : pool_(pool), settings_(settings) {
  if (pool_ == nullptr) throw std::invalid_argument("Rasterizer: thread pool is null");
  if (!(settings.radius_sigma > 0) || !(settings.min_alpha >= 0) || !(settings.min_transmittance >= 0)) {
    throw std::invalid_argument("Rasterizer: radius_sigma must be > 0, min_alpha and min_transmittance >= 0");
  }
}

template <typename T>
void Rasterizer<T>::preprocess() {
  const int n = params_.count;
  packed_.resize(n);
  visible_.resize(n);
  const int K3 = 3 * gs::shCoeffCount(params_.sh_degree);
  const T radius_sigma = T(settings_.radius_sigma), min_alpha = T(settings_.min_alpha);
  const int width = view_.width, height = view_.height;
  constexpr int kBlock = 1024;
  pool_->parallelFor((n + kBlock - 1) / kBlock, [&](int b, int) {
    const int begin = b * kBlock, end = std::min(n, (b + 1) * kBlock);
    // Cheap pre-test over the block (SIMD): most off-screen Gaussians leave here, before the
    // covariance and the SH colour. Only visible Gaussians write their (cache-line) Packed record.
    // Rows of 3 transposed to columns first (the vectoriser does not handle the stride-3 loads).
    alignas(64) T X[kBlock], Y[kBlock], Z[kBlock], L0[kBlock], L1[kBlock], L2[kBlock];
    alignas(64) T may[kBlock];  // 1 = may reach the image
    const gs::PinholeView<T> cam = view_;
    const T* pos = params_.position + 3 * begin;
    const T* ls = params_.log_scale + 3 * begin;
    const int count = end - begin;
    for (int j = 0; j < count; ++j) {
      X[j] = pos[3 * j];
      Y[j] = pos[3 * j + 1];
      Z[j] = pos[3 * j + 2];
      L0[j] = ls[3 * j];
      L1[j] = ls[3 * j + 1];
      L2[j] = ls[3 * j + 2];
    }
#pragma omp simd
    for (int j = 0; j < count; ++j) {
      may[j] = gs::imageReachMargin(cam, X[j], Y[j], Z[j], L0[j], L1[j], L2[j], radius_sigma) >= T(0) ? T(1) : T(0);
    }
    for (int i = begin; i < end; ++i) {
      visible_[i] = 0;
      if (may[i - begin] == T(0)) continue;
      gs::Projected<T> pr;
      if (!gs::projectGaussian(view_, params_.position + 3 * i, params_.log_scale + 3 * i,
                               params_.rotation + 4 * i, params_.opacity_logit[i], params_.sh + K3 * i,
                               params_.sh_degree, radius_sigma, min_alpha, pr)) {
        continue;
      }
      const T ru = pr.half_u, rv = pr.half_v;
      if (!(pr.mean_u + ru >= T(-0.5)) || !(pr.mean_u - ru <= T(width) - T(0.5)) || !(pr.mean_v + rv >= T(-0.5)) ||
          !(pr.mean_v - rv <= T(height) - T(0.5))) {
        continue;  // off screen (also rejects NaN)
      }
      Packed& p = packed_[i];
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
      p.tile_x0 = std::max(0, static_cast<int>(std::floor((pr.mean_u - ru + T(0.5)) / gs::kTileSize)));
      p.tile_x1 = std::min(tiles_x_, static_cast<int>(std::floor((pr.mean_u + ru + T(0.5)) / gs::kTileSize)) + 1);
      p.tile_y0 = std::max(0, static_cast<int>(std::floor((pr.mean_v - rv + T(0.5)) / gs::kTileSize)));
      p.tile_y1 = std::min(tiles_y_, static_cast<int>(std::floor((pr.mean_v + rv + T(0.5)) / gs::kTileSize)) + 1);
      visible_[i] = p.tile_x1 > p.tile_x0 && p.tile_y1 > p.tile_y0;
    }
  });
}

namespace {

/// LSD radix sort of (key, value) pairs on 32-bit keys, 3 passes of 11 bits; stable.
void radixSort(std::vector<std::uint32_t>& keys, std::vector<std::uint32_t>& values,
               std::vector<std::uint32_t>& tmp_keys, std::vector<std::uint32_t>& tmp_values) {
  const std::size_t n = keys.size();
  tmp_keys.resize(n);
  tmp_values.resize(n);
  constexpr int kBits = 11, kBuckets = 1 << kBits;
  std::uint32_t count[kBuckets];
  for (int pass = 0; pass < 3; ++pass) {
    const int shift = pass * kBits;
    std::memset(count, 0, sizeof(count));
    for (std::size_t i = 0; i < n; ++i) ++count[(keys[i] >> shift) & (kBuckets - 1)];
    std::uint32_t sum = 0;
    for (int b = 0; b < kBuckets; ++b) {
      const std::uint32_t c = count[b];
      count[b] = sum;
      sum += c;
    }
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t slot = count[(keys[i] >> shift) & (kBuckets - 1)]++;
      tmp_keys[slot] = keys[i];
      tmp_values[slot] = values[i];
    }
    keys.swap(tmp_keys);
    values.swap(tmp_values);
  }
}

}  // namespace

template <typename T>
void Rasterizer<T>::binTiles() {
  const int n = params_.count;
  const int num_tiles = tiles_x_ * tiles_y_;
  keys_.clear();
  order_.clear();
  tile_ranges_.assign(num_tiles + 1, 0);
  for (int i = 0; i < n; ++i) {
    if (!visible_[i]) continue;
    const Packed& p = packed_[i];
    const float d = static_cast<float>(p.depth);  // > 0: IEEE bits order like the values
    std::uint32_t bits;
    std::memcpy(&bits, &d, sizeof(bits));
    keys_.push_back(bits);
    order_.push_back(static_cast<std::uint32_t>(i));
    for (int ty = p.tile_y0; ty < p.tile_y1; ++ty)
      for (int tx = p.tile_x0; tx < p.tile_x1; ++tx) ++tile_ranges_[ty * tiles_x_ + tx + 1];
  }
  num_visible_ = order_.size();
  // Sort on the top 32 bits of the depth (2^-23 relative resolution), stable.
  radixSort(keys_, order_, sort_tmp_keys_, sort_tmp_order_);
  for (int t = 0; t < num_tiles; ++t) tile_ranges_[t + 1] += tile_ranges_[t];
  entries_.resize(tile_ranges_[num_tiles]);
  tile_fill_.assign(tile_ranges_.begin(), tile_ranges_.end() - 1);
  // Copy the visible Gaussians in depth order: tile lists then read memory in increasing order.
  sorted_.resize(num_visible_);
  rank_.assign(n, kNotVisible);
  for (std::uint32_t j = 0; j < num_visible_; ++j) {
    if (j + kPrefetchAhead < num_visible_) __builtin_prefetch(&packed_[order_[j + kPrefetchAhead]]);
    const Packed& p = packed_[order_[j]];
    rank_[order_[j]] = j;
    sorted_[j] = p;
    for (int ty = p.tile_y0; ty < p.tile_y1; ++ty)
      for (int tx = p.tile_x0; tx < p.tile_x1; ++tx) entries_[tile_fill_[ty * tiles_x_ + tx]++] = j;
  }
}

template <typename T>
void Rasterizer<T>::forward(const GaussianParamsView<T>& params, const gs::PinholeView<T>& view, RenderResult<T>& out) {
  if (view.width <= 0 || view.height <= 0 || !(view.fx > 0) || !(view.fy > 0)) {
    throw std::invalid_argument("Rasterizer::forward: invalid camera (size and focal lengths must be > 0)");
  }
  if (params.count < 0 || params.sh_degree < 0 || params.sh_degree > gs::kMaxShDegree) {
    throw std::invalid_argument("Rasterizer::forward: bad Gaussian count or SH degree");
  }
  params_ = params;
  view_ = view;
  tiles_x_ = (view.width + gs::kTileSize - 1) / gs::kTileSize;
  tiles_y_ = (view.height + gs::kTileSize - 1) / gs::kTileSize;
  const std::size_t npix = static_cast<std::size_t>(view.width) * view.height;
  out.width = view.width;
  out.height = view.height;
  out.color.resize(3 * npix);
  out.depth.resize(npix);
  out.alpha.resize(npix);
  final_T_.resize(npix);
  last_entry_.resize(npix);
  const auto t0 = std::chrono::steady_clock::now();
  preprocess();
  const auto t1 = std::chrono::steady_clock::now();
  binTiles();
  const auto t2 = std::chrono::steady_clock::now();
  pool_->parallelFor(tiles_x_ * tiles_y_, [&](int tile, int) { forwardTile(tile, out); });
  const auto t3 = std::chrono::steady_clock::now();
  using Ms = std::chrono::duration<double, std::milli>;
  times_.project_ms = Ms(t1 - t0).count();
  times_.bin_ms = Ms(t2 - t1).count();
  times_.composite_ms = Ms(t3 - t2).count();
}

template <typename T>
void Rasterizer<T>::forwardTile(int tile, RenderResult<T>& out) {
  constexpr int S = gs::kTileSize;
  const int tx0 = (tile % tiles_x_) * S, ty0 = (tile / tiles_x_) * S;
  const int tx1 = std::min(tx0 + S, view_.width), ty1 = std::min(ty0 + S, view_.height);
  alignas(64) T Tr[gs::kTilePixels], Cr[gs::kTilePixels], Cg[gs::kTilePixels], Cb[gs::kTilePixels], D[gs::kTilePixels];
  alignas(64) T live[gs::kTilePixels];  // 1 while the pixel still composites, 0 once stopped
  alignas(64) std::uint32_t last[gs::kTilePixels];
  const std::uint32_t begin = tile_ranges_[tile], end = tile_ranges_[tile + 1];
  for (int i = 0; i < gs::kTilePixels; ++i) {
    Tr[i] = T(1);
    Cr[i] = Cg[i] = Cb[i] = D[i] = T(0);
    last[i] = begin;
    // Pixels outside the image (partial tiles) never composite.
    const int px = tx0 + i % S, py = ty0 + i / S;
    live[i] = (px >= tx1 || py >= ty1) ? T(0) : T(1);
  }
  const T min_alpha = T(settings_.min_alpha), min_T = T(settings_.min_transmittance), max_alpha = T(gs::kMaxAlpha);
  for (std::uint32_t k = begin; k < end; ++k) {
    // The tile's Gaussians are scattered over sorted_ (global depth order): fetch ahead.
    if (k + kPrefetchAhead < end) __builtin_prefetch(&sorted_[entries_[k + kPrefetchAhead]]);
    const Packed& p = sorted_[entries_[k]];
    // Rows of the footprint box inside the tile; every row is processed over the full tile width
    // (fixed trip count, vectorised); pixels outside the box fall below min_alpha by construction.
    const auto [py0, py1, xb0, xb1] = p.windowInTile(tx0, ty0, ty1, S);
    const T a = p.conic_a, b = p.conic_b, c = p.conic_c, o = p.opacity;
    const T c0 = p.color[0], c1 = p.color[1], c2 = p.color[2], dep = p.depth;
    const T mu0 = p.mean_u - T(tx0);
    for (int py = py0; py < py1; ++py) {
      const T dy = p.mean_v - T(py);
      const T row_term = T(-0.5) * c * dy * dy;
      const T bdy = b * dy;
      const int row = (py - ty0) * S;
      for (int xb = xb0; xb < xb1; xb += 8)
#pragma omp simd
      for (int x = xb; x < xb + 8; ++x) {
        const int i = row + x;
        const T dx = mu0 - T(x);
        const T power = T(-0.5) * a * dx * dx - bdy * dx + row_term;
        T alpha = o * gs::blendExp(power);
        alpha = alpha < max_alpha ? alpha : max_alpha;
        // 0/1 masks in float arithmetic (keeps the loop branch-free and vectorised).
        const T ok = (power <= T(0) ? T(1) : T(0)) * (alpha >= min_alpha ? T(1) : T(0)) * live[i];
        const T test_T = Tr[i] * (T(1) - alpha);
        const T stop = ok * (test_T < min_T ? T(1) : T(0));
        const T use = ok - stop;
        const T w = use * alpha * Tr[i];
        Cr[i] += w * c0;
        Cg[i] += w * c1;
        Cb[i] += w * c2;
        D[i] += w * dep;
        Tr[i] += use * (test_T - Tr[i]);
        last[i] = use > T(0) ? k + 1 : last[i];
        live[i] -= stop;
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
  const std::size_t npix = static_cast<std::size_t>(view_.width) * view_.height;
  const int w = tx1 - tx0;
  auto copyRow = [&](int row, std::size_t o, auto width) {
    std::memcpy(&out.color[o], &Cr[row], width * sizeof(T));
    std::memcpy(&out.color[npix + o], &Cg[row], width * sizeof(T));
    std::memcpy(&out.color[2 * npix + o], &Cb[row], width * sizeof(T));
    std::memcpy(&out.depth[o], &D[row], width * sizeof(T));
    std::memcpy(&out.alpha[o], &A[row], width * sizeof(T));
    std::memcpy(&final_T_[o], &Tr[row], width * sizeof(T));
    std::memcpy(&last_entry_[o], &last[row], width * sizeof(std::uint32_t));
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
}

template class Rasterizer<float>;
template class Rasterizer<double>;

}  // namespace dypho::mapping
