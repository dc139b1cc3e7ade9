/// Rasterizer: the backward pass (per-tile back-to-front in the tile kernels, then the per-Gaussian
/// chain rule).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "dypho/mapping/rasterizer.h"

namespace dypho::mapping {

namespace {

/// Sizes every output of `out` for n Gaussians with K3 SH values each.
template <typename T>
void resizeGrads(int n, int K3, GaussianGrads<T>& out) {
  out.position.resize(3 * n);
  out.log_scale.resize(3 * n);
  out.rotation.resize(4 * n);
  out.opacity_logit.resize(n);
  out.sh.resize(static_cast<std::size_t>(K3) * n);
  out.mean2d_norm.resize(n);
}

/// Zeros the output rows of Gaussians [begin, end) (block fills).
template <typename T>
void zeroGradRows(int begin, int end, int K3, GaussianGrads<T>& out) {
  std::fill(out.position.begin() + 3 * begin, out.position.begin() + 3 * end, T(0));
  std::fill(out.log_scale.begin() + 3 * begin, out.log_scale.begin() + 3 * end, T(0));
  std::fill(out.rotation.begin() + 4 * begin, out.rotation.begin() + 4 * end, T(0));
  std::fill(out.opacity_logit.begin() + begin, out.opacity_logit.begin() + end, T(0));
  std::fill(out.sh.begin() + static_cast<std::size_t>(K3) * begin, out.sh.begin() + static_cast<std::size_t>(K3) * end,
            T(0));
  std::fill(out.mean2d_norm.begin() + begin, out.mean2d_norm.begin() + end, T(0));
}

/// The screen gradient of visible Gaussian j: the per-thread sums added in thread order.
template <typename T>
gs::ScreenGrad<T> sumThreadGrads(const std::vector<std::vector<gs::ScreenGrad<T>>>& thread_grads, std::uint32_t j) {
  const int threads = static_cast<int>(thread_grads.size());
  gs::ScreenGrad<T> sg = thread_grads[0][j];
  for (int t = 1; t < threads; ++t) {
    const gs::ScreenGrad<T>& s = thread_grads[t][j];
    sg.mean_u += s.mean_u;
    sg.mean_v += s.mean_v;
    sg.conic_a += s.conic_a;
    sg.conic_b += s.conic_b;
    sg.conic_c += s.conic_c;
    sg.opacity += s.opacity;
    sg.depth += s.depth;
    for (int ch = 0; ch < 3; ++ch) sg.color[ch] += s.color[ch];
  }
  return sg;
}

/// True when every component of the screen gradient is zero.
template <typename T>
bool isZeroScreenGrad(const gs::ScreenGrad<T>& sg) {
  return sg.mean_u == T(0) && sg.mean_v == T(0) && sg.conic_a == T(0) && sg.conic_b == T(0) && sg.conic_c == T(0) &&
         sg.opacity == T(0) && sg.depth == T(0) && sg.color[0] == T(0) && sg.color[1] == T(0) && sg.color[2] == T(0);
}

/// Writes Gaussian i's parameter gradients into its output rows and adds its pose gradient to `pose`.
template <typename T>
void writeParamGrad(const gs::ParamGrad<T>& pg, int i, int K3, GaussianGrads<T>& out, T* pose) {
  for (int k = 0; k < 3; ++k) {
    out.position[3 * i + k] = pg.pos[k];
    out.log_scale[3 * i + k] = pg.log_scale[k];
  }
  for (int k = 0; k < 4; ++k) out.rotation[4 * i + k] = pg.quat[k];
  out.opacity_logit[i] = pg.opacity_logit;
  for (int k = 0; k < K3; ++k) out.sh[static_cast<std::size_t>(K3) * i + k] = pg.sh[k];
  for (int k = 0; k < 6; ++k) pose[k] += pg.pose[k];
}

}  // namespace

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
  const raster::TileLists<T> lists = tileLists();
  const raster::BackwardInputs<T> inputs{final_T_.data(), last_entry_.data(), grads};
  pool_->parallelForStatic(tiles_x_ * tiles_y_, [&](int tile, int thread) {
    kernels_.backward(lists, tile, inputs, thread_grads_[thread].data());
  });
  const auto t1 = std::chrono::steady_clock::now();

  // Chain rule per Gaussian, in parameter order (sequential reads of the parameters and writes
  // of the outputs; every output row is written, zeros for Gaussians without a gradient).
  const int K3 = 3 * gs::shCoeffCount(params_.sh_degree);
  resizeGrads(n, K3, out);
  const int block = 1024;
  pool_->parallelForStatic((n + block - 1) / block, [&](int bi, int thread) {
    const int begin = bi * block, end = std::min(n, (bi + 1) * block);
    T* pose = thread_pose_[thread].data();
    // Zeros first (block fills), then the Gaussians with a gradient overwrite their rows.
    zeroGradRows(begin, end, K3, out);
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
      const gs::ScreenGrad<T> sg = sumThreadGrads(thread_grads_, j);
      // Not visible, or touched no pixel with a gradient (occluded, or where the loss is flat):
      // every gradient is zero, as filled above.
      if (isZeroScreenGrad(sg)) continue;
      out.mean2d_norm[i] = std::sqrt(sg.mean_u * sg.mean_u + sg.mean_v * sg.mean_v);
      gs::ParamGrad<T> pg;
      gs::projectGaussianBackward(view_, params_.position + 3 * i, params_.log_scale + 3 * i, params_.rotation + 4 * i,
                                  params_.opacity_logit[i], params_.sh + K3 * i, params_.sh_degree, sg, pg);
      writeParamGrad(pg, i, K3, out, pose);
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

}  // namespace dypho::mapping
