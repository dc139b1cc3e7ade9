/// Rasterizer: projection, binning and the forward compositing pass.
#include "dypho/mapping/rasterizer.h"

#include "raster_tile_kernels.h"

#include "dypho/mapping/blend_steps.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace dypho::mapping {

const char* rasterIsaName(RasterIsa isa) {
  switch (isa) {
    case RasterIsa::kAuto:
      return "auto";
    case RasterIsa::kGeneric:
      return "generic";
    case RasterIsa::kAvx2:
      return "avx2";
  }
  return "unknown";
}

bool rasterAvx2Available() {
#if DYPHO_RASTER_HAVE_AVX2 && (defined(__x86_64__) || defined(__i386__))
  // libgcc's CPU model also checks that the OS saves the AVX registers (XGETBV).
  static const bool available = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  }();
  return available;
#else
  return false;
#endif
}

template <typename T>
Rasterizer<T>::Rasterizer(ThreadPool* pool, const RasterSettings& settings) : pool_(pool), settings_(settings) {
  if (pool_ == nullptr) throw std::invalid_argument("Rasterizer: thread pool is null");
  if (!(settings.radius_sigma > 0) || !(settings.min_alpha >= 0) || !(settings.min_transmittance >= 0)) {
    throw std::invalid_argument("Rasterizer: radius_sigma must be > 0, min_alpha and min_transmittance >= 0");
  }
  isa_ = settings.isa;
  if (isa_ == RasterIsa::kAuto) isa_ = rasterAvx2Available() ? RasterIsa::kAvx2 : RasterIsa::kGeneric;
  if (isa_ == RasterIsa::kAvx2) {
    if (!rasterAvx2Available()) {
      throw std::invalid_argument(
          "Rasterizer: isa avx2 requested, but this CPU has no AVX2+FMA or this build has no AVX2 kernels "
          "(use auto or generic)");
    }
#if DYPHO_RASTER_HAVE_AVX2
    kernels_.forward = &raster::avx2::forwardTile<T>;
    kernels_.backward = &raster::avx2::backwardTile<T>;
#endif
  } else {
    kernels_.forward = &raster::generic::forwardTile<T>;
    kernels_.backward = &raster::generic::backwardTile<T>;
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
      if (!gs::projectGaussian(view_, params_.position + 3 * i, params_.log_scale + 3 * i, params_.rotation + 4 * i,
                               params_.opacity_logit[i], params_.sh + K3 * i, params_.sh_degree, radius_sigma,
                               min_alpha, pr)) {
        continue;
      }
      visible_[i] = gs::packProjected(pr, width, height, tiles_x_, tiles_y_, packed_[i]) ? 1 : 0;
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
  const raster::TileLists<T> lists = tileLists();
  const raster::ForwardImages<T> images{out.color.data(), out.depth.data(), out.alpha.data(), final_T_.data(),
                                        last_entry_.data()};
  pool_->parallelFor(tiles_x_ * tiles_y_, [&](int tile, int) { kernels_.forward(lists, tile, images); });
  const auto t3 = std::chrono::steady_clock::now();
  using Ms = std::chrono::duration<double, std::milli>;
  times_.project_ms = Ms(t1 - t0).count();
  times_.bin_ms = Ms(t2 - t1).count();
  times_.composite_ms = Ms(t3 - t2).count();
}

template <typename T>
raster::TileLists<T> Rasterizer<T>::tileLists() const {
  raster::TileLists<T> lists;
  lists.tiles_x = tiles_x_;
  lists.width = view_.width;
  lists.height = view_.height;
  lists.ranges = tile_ranges_.data();
  lists.entries = entries_.data();
  lists.sorted = sorted_.data();
  lists.min_alpha = T(settings_.min_alpha);
  lists.min_transmittance = T(settings_.min_transmittance);
  return lists;
}

template class Rasterizer<float>;
template class Rasterizer<double>;

}  // namespace dypho::mapping
