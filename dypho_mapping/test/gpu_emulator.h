#pragma once
/// \file gpu_emulator.h
/// The CUDA path's kernels run on the CPU for the tests: each kernel is a loop over its grid that
/// calls the kernel's body (src/cuda/kernel_bodies.h), in the kernels' order, with
/// std::stable_sort in place of the CUB radix sort (both stable, same keys). Only what needs the
/// hardware (atomics, warp sums, the lockstep walk) is left out. No OpenCV.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "dypho/mapping/cuda_trainer.h"
#include "dypho/mapping/rasterizer.h"
#include "kernel_bodies.h"

namespace dypho::mapping::gpu_emulator {

namespace body = cuda_body;

/// The GPU pipeline with loops for the grid.
class EmulatedGpuRasterizer {
 public:
  explicit EmulatedGpuRasterizer(const RasterSettings& s) : settings_(s) {}

  void forward(const GaussianParamsView<float>& P, const gs::PinholeView<float>& cam, RenderResult<float>& out) {
    P_ = P;
    cam_ = cam;
    tiles_x_ = (cam.width + body::S - 1) / body::S;
    tiles_y_ = (cam.height + body::S - 1) / body::S;
    const int n = P.count;
    packed_.assign(n, body::Packed{});
    touched_.assign(n, 0);
    visible_ = 0;
    for (int i = 0; i < n; ++i) {  // preprocessKernel
      touched_[i] = body::preprocess(i, P, cam, static_cast<float>(settings_.radius_sigma),
                                     static_cast<float>(settings_.min_alpha), tiles_x_, tiles_y_, packed_.data());
      visible_ += touched_[i] > 0;
    }
    std::vector<std::uint32_t> offsets(n);
    std::inclusive_scan(touched_.begin(), touched_.end(), offsets.begin());  // cub::DeviceScan::InclusiveSum
    const std::uint32_t total = n > 0 ? offsets.back() : 0;
    std::vector<unsigned long long> keys(total);
    std::vector<std::uint32_t> values(total);
    for (int i = 0; i < n; ++i)
      body::emitKeys(i, packed_.data(), touched_.data(), offsets.data(), tiles_x_, keys.data(), values.data());
    // cub::DeviceRadixSort::SortPairs: stable, ascending keys.
    std::vector<std::uint32_t> order(total);
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
    std::vector<unsigned long long> keys_sorted(total);
    values_.resize(total);
    for (std::uint32_t k = 0; k < total; ++k) {
      keys_sorted[k] = keys[order[k]];
      values_[k] = values[order[k]];
    }
    ranges_.assign(static_cast<std::size_t>(tiles_x_) * tiles_y_, body::TileRange{0, 0});
    for (std::uint32_t k = 0; k < total; ++k) body::tileRange(k, total, keys_sorted.data(), ranges_.data());
    entries_ = total;
    const std::size_t npix = static_cast<std::size_t>(cam.width) * cam.height;
    out.width = cam.width;
    out.height = cam.height;
    out.color.assign(3 * npix, -1.f);  // every pixel must be written
    out.depth.assign(npix, -1.f);
    out.alpha.assign(npix, -1.f);
    final_T_.assign(npix, -1.f);
    last_.assign(npix, 0);
    const body::ForwardOut fo{out.color.data(), out.depth.data(), out.alpha.data(), final_T_.data(), last_.data()};
    for (int by = 0; by < tiles_y_; ++by)  // forwardKernel
      for (int bx = 0; bx < tiles_x_; ++bx)
        for (int ly = 0; ly < body::S; ++ly)
          for (int lx = 0; lx < body::S; ++lx) {
            const body::TilePixel t = body::tilePixel(bx, by, lx, ly, cam.width, cam.height);
            body::forwardPixel(t, cam.width, cam.height, ranges_[by * tiles_x_ + bx], values_.data(), packed_.data(),
                               static_cast<float>(settings_.min_alpha), static_cast<float>(settings_.min_transmittance),
                               fo);
          }
  }

  void backward(const PixelGrads<float>& g, GaussianGrads<float>& out) {
    const int n = P_.count;
    std::vector<gs::ScreenGrad<float>> screen(n, gs::ScreenGrad<float>{});
    for (int by = 0; by < tiles_y_; ++by)  // backwardKernel: the block's lockstep walk
      for (int bx = 0; bx < tiles_x_; ++bx) {
        const body::TileRange range = ranges_[by * tiles_x_ + bx];
        std::vector<body::TilePixel> px;
        std::vector<body::BackwardStart> start;
        std::uint32_t block_last = range.begin;
        for (int ly = 0; ly < body::S; ++ly)
          for (int lx = 0; lx < body::S; ++lx) {
            px.push_back(body::tilePixel(bx, by, lx, ly, cam_.width, cam_.height));
            start.push_back(body::backwardStart(px.back(), cam_.width, cam_.height, range, final_T_.data(),
                                                last_.data(), g.color, g.depth, g.alpha));
            block_last = std::max(block_last, start.back().last);
          }
        for (std::uint32_t k = block_last; k-- > range.begin;) {
          const std::uint32_t gi = values_[k];
          for (std::size_t j = 0; j < px.size(); ++j) {
            gs::ScreenGrad<float> s{};
            if (!body::backwardPixelStep(px[j], k, packed_[gi], static_cast<float>(settings_.min_alpha), start[j], s))
              continue;
            gs::ScreenGrad<float>& a = screen[gi];
            a.mean_u += s.mean_u;
            a.mean_v += s.mean_v;
            a.conic_a += s.conic_a;
            a.conic_b += s.conic_b;
            a.conic_c += s.conic_c;
            a.opacity += s.opacity;
            a.depth += s.depth;
            for (int c = 0; c < 3; ++c) a.color[c] += s.color[c];
          }
        }
      }
    const int K3 = 3 * gs::shCoeffCount(P_.sh_degree);
    out.position.assign(3 * n, 7.f);  // every row must be written
    out.log_scale.assign(3 * n, 7.f);
    out.rotation.assign(4 * n, 7.f);
    out.opacity_logit.assign(n, 7.f);
    out.sh.assign(static_cast<std::size_t>(K3) * n, 7.f);
    out.mean2d_norm.assign(n, 7.f);
    const body::ParamGradsOut po{out.position.data(),      out.log_scale.data(), out.rotation.data(),
                                 out.opacity_logit.data(), out.sh.data(),        out.mean2d_norm.data()};
    double pose[6] = {0, 0, 0, 0, 0, 0};
    for (int i = 0; i < n; ++i) {  // chainKernel
      float part[6];
      body::chain(i, P_, cam_, touched_[i] > 0, screen[i], po, part);
      for (int k = 0; k < 6; ++k) pose[k] += part[k];
    }
    for (int k = 0; k < 6; ++k) out.pose[k] = static_cast<float>(pose[k]);
  }

  std::size_t numVisible() const { return visible_; }
  std::size_t numTileEntries() const { return entries_; }

 private:
  RasterSettings settings_;
  GaussianParamsView<float> P_{};
  gs::PinholeView<float> cam_{};
  int tiles_x_ = 0, tiles_y_ = 0;
  std::size_t visible_ = 0, entries_ = 0;
  std::vector<body::Packed> packed_;
  std::vector<std::uint32_t> touched_, values_, last_;
  std::vector<body::TileRange> ranges_;
  std::vector<float> final_T_;
};

/// Training state on the host in the device layout (blocks of rows; widths 3, 3, 4, 1, 3).
struct HostState {
  std::vector<float> params[5], m[5], v[5];
  std::vector<float> accum;
  std::vector<int> count;
  std::size_t n = 0;
  static constexpr int kWidths[5] = {3, 3, 4, 1, 3};
  body::StateBlocks blocks() {
    body::StateBlocks b{};
    for (int p = 0; p < 5; ++p) {
      b.params[p] = params[p].data();
      b.m[p] = m[p].data();
      b.v[p] = v[p].data();
      b.widths[p] = kWidths[p];
    }
    return b;
  }
  void add(float x, float log_scale, float opacity_logit, float grad_sum, int grad_count) {
    const float row[5][4] = {{x, 0.f, 2.f},
                             {log_scale, log_scale - 1.f, log_scale - 2.f},
                             {0.9f, 0.1f, 0.2f, 0.3f},
                             {opacity_logit},
                             {0.1f, 0.2f, 0.3f}};
    for (int p = 0; p < 5; ++p) {
      params[p].insert(params[p].end(), row[p], row[p] + kWidths[p]);
      m[p].insert(m[p].end(), kWidths[p], 0.5f);  // non-zero moments: kept rows must keep them
      v[p].insert(v[p].end(), kWidths[p], 0.25f);
    }
    accum.push_back(grad_sum);
    count.push_back(grad_count);
    ++n;
  }
};

/// CudaTrainer::densifyAndPrune's kernels in order, on the CPU.
inline DensifyOutcome emulateDensify(HostState& st, const DensifySettings& s, std::size_t capacity) {
  DensifyOutcome out;
  const std::size_t n0 = st.n;
  std::vector<std::uint32_t> children(n0), offsets(n0);
  for (std::size_t i = 0; i < n0; ++i)
    children[i] = body::densifyChildren(i, st.accum.data(), st.count.data(), st.params[1].data(), s);
  std::exclusive_scan(children.begin(), children.end(), offsets.begin(), 0u);
  const std::size_t wanted = offsets.back() + children.back(), room = capacity > n0 ? capacity - n0 : 0;
  const std::size_t added = std::min(wanted, room);
  out.capacity_hit = wanted > room;
  const std::size_t n1 = n0 + added;
  for (int p = 0; p < 5; ++p) {
    st.params[p].resize(n1 * HostState::kWidths[p], -99.f);
    st.m[p].resize(n1 * HostState::kWidths[p], -99.f);
    st.v[p].resize(n1 * HostState::kWidths[p], -99.f);
  }
  out.parents.assign(added, 0xffffffffu);
  std::vector<std::uint8_t> split_done(n0);
  const body::StateBlocks b = st.blocks();
  for (std::size_t i = 0; i < n0; ++i) {  // spawnKernel
    for (std::uint32_t k = 0; k < children[i] && offsets[i] + k < added; ++k) {
      body::spawnChild(i, k, children[i] == 2, n0 + offsets[i] + k, b, s.seed);
      out.parents[offsets[i] + k] = static_cast<std::uint32_t>(i);
    }
    split_done[i] = children[i] == 2 && offsets[i] + 1 < added;
  }
  out.remove.resize(n1);
  std::vector<std::uint32_t> keep(n1), keep_offsets(n1);
  for (std::size_t r = 0; r < n1; ++r) {  // pruneKernel
    out.remove[r] = body::pruned(r, r < n0 && split_done[r], b, s) ? 1 : 0;
    keep[r] = out.remove[r] ? 0 : 1;
  }
  std::exclusive_scan(keep.begin(), keep.end(), keep_offsets.begin(), 0u);
  const std::size_t kept = keep_offsets.back() + keep.back();
  HostState dst;
  for (int p = 0; p < 5; ++p) {
    dst.params[p].resize(kept * HostState::kWidths[p]);
    dst.m[p].resize(kept * HostState::kWidths[p]);
    dst.v[p].resize(kept * HostState::kWidths[p]);
  }
  const body::StateBlocks d = dst.blocks();
  for (std::size_t r = 0; r < n1; ++r)  // compactKernel
    if (!out.remove[r]) body::moveRow(r, keep_offsets[r], b, d);
  dst.n = kept;
  dst.accum.assign(kept, 0.f);
  dst.count.assign(kept, 0);
  st = dst;
  return out;
}

}  // namespace dypho::mapping::gpu_emulator
