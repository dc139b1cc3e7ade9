/// Masked SSIM and its gradient (see ssim_loss.h for the definition).
#include "dypho/mapping/ssim_loss.h"

#include "dypho/mapping/ssim_math.h"

#include <algorithm>
#include <cmath>

namespace dypho::mapping {
namespace {

constexpr int kRadius = SsimLoss<float>::kWindow / 2;

/// out[u] = sum_k taps[k] in[u + k - R], zero outside [0, W). `pad` has W + 2R entries.
template <typename T>
void convolveRow(const T* in, int W, const T* taps, T* pad, T* out) {
  std::fill(pad, pad + kRadius, T(0));
  std::copy(in, in + W, pad + kRadius);
  std::fill(pad + kRadius + W, pad + W + 2 * kRadius, T(0));
  for (int u = 0; u < W; ++u) out[u] = T(0);
  for (int k = 0; k < SsimLoss<float>::kWindow; ++k) {
    const T t = taps[k];
    const T* p = pad + k;
#pragma omp simd
    for (int u = 0; u < W; ++u) out[u] += t * p[u];
  }
}

/// out[u] = sum_k taps[k] plane[(v + k - R) W + u] over the rows inside [0, H).
template <typename T>
void convolveColumn(const T* plane, int W, int H, int v, const T* taps, T* out) {
  for (int u = 0; u < W; ++u) out[u] = T(0);
  const int k0 = std::max(0, kRadius - v), k1 = std::min(SsimLoss<float>::kWindow, H - v + kRadius);
  for (int k = k0; k < k1; ++k) {
    const T t = taps[k];
    const T* p = plane + static_cast<std::size_t>(v + k - kRadius) * W;
#pragma omp simd
    for (int u = 0; u < W; ++u) out[u] += t * p[u];
  }
}

/// The working planes of one SSIM evaluation (SsimLoss's buffers, sized for W x H).
template <typename T>
struct SsimPlanes {
  int W, H;
  const T* taps;                  ///< [kWindow] window taps
  const std::uint8_t* static_px;  ///< [HW] 1 = static
  T* x;                           ///< [3HW] composited rendered image x' = M x + (1 - M) y
  T* y;                           ///< [3HW] target
  T* h[5];                        ///< [3HW] horizontal passes (reused by the backward)
  T* p[3];                        ///< [3HW] per-pixel dS/d(mu_x, sxx, sxy) terms
};

/// Writes 1 (static) or 0 per pixel of the H x W mask (rows of `mask_step` bytes, nonzero =
/// static; null = all static) into `static_px`; returns how many are static.
std::size_t markStaticPixels(const std::uint8_t* static_mask, std::size_t mask_step, int W, int H,
                             std::uint8_t* static_px) {
  std::size_t n_static = 0;
  for (int v = 0; v < H; ++v) {
    const std::uint8_t* m = static_mask ? static_mask + v * mask_step : nullptr;
    std::uint8_t* s = static_px + static_cast<std::size_t>(v) * W;
    for (int u = 0; u < W; ++u) {
      s[u] = (!m || m[u]) ? 1 : 0;
      n_static += s[u];
    }
  }
  return n_static;
}

/// Step 1 on plane row r ([3H] rows): composite x' = M x + (1 - M) y, then the horizontal pass of
/// x', y, x'^2, y^2, x'y into h[0..4]. `pad`: 2 (W + 2R) scratch values.
template <typename T>
void compositeAndFilterRow(const SsimPlanes<T>& b, int r, const T* rendered, const T* target, T* pad) {
  const int W = b.W, H = b.H;
  const std::size_t pad_len = static_cast<std::size_t>(W + 2 * kRadius);
  const int v = r % H;
  const std::size_t row = static_cast<std::size_t>(r) * W;
  const std::uint8_t* s = b.static_px + static_cast<std::size_t>(v) * W;
  T* x = b.x + row;
  T* y = b.y + row;
  for (int u = 0; u < W; ++u) {
    y[u] = target[row + u];
    x[u] = s[u] ? rendered[row + u] : y[u];
  }
  T* prod = pad + pad_len;  // one row of products
  convolveRow(x, W, b.taps, pad, b.h[0] + row);
  convolveRow(y, W, b.taps, pad, b.h[1] + row);
  for (int u = 0; u < W; ++u) prod[u] = x[u] * x[u];
  convolveRow(prod, W, b.taps, pad, b.h[2] + row);
  for (int u = 0; u < W; ++u) prod[u] = y[u] * y[u];
  convolveRow(prod, W, b.taps, pad, b.h[3] + row);
  for (int u = 0; u < W; ++u) prod[u] = x[u] * y[u];
  convolveRow(prod, W, b.taps, pad, b.h[4] + row);
}

/// Step 2 on plane row r: vertical pass -> window statistics -> SSIM (into `ssim_map` when not
/// null) and, with `want_grad`, the per-pixel terms p[0..2]. Returns the row's SSIM summed over
/// its static pixels. `acc`: 5 W scratch values.
template <typename T>
double ssimRow(const SsimPlanes<T>& b, int r, bool want_grad, T* ssim_map, T* acc) {
  const int W = b.W, H = b.H;
  const int c = r / H, v = r % H;
  const std::size_t row = static_cast<std::size_t>(r) * W;
  const std::size_t plane = static_cast<std::size_t>(c) * W * H;
  for (int j = 0; j < 5; ++j) convolveColumn(b.h[j] + plane, W, H, v, b.taps, acc + j * W);
  const std::uint8_t* s = b.static_px + static_cast<std::size_t>(v) * W;
  double sum = 0.0;
  for (int u = 0; u < W; ++u) {
    const ssim::PixelSsim<T> px =
        ssim::pixelSsim(acc[u], acc[W + u], acc[2 * W + u], acc[3 * W + u], acc[4 * W + u], s[u] ? T(1) : T(0));
    if (ssim_map) ssim_map[row + u] = px.S;
    if (s[u]) sum += static_cast<double>(px.S);
    if (want_grad) {
      b.p[0][row + u] = px.p0;
      b.p[1][row + u] = px.p1;
      b.p[2][row + u] = px.p2;
    }
  }
  return sum;
}

/// Step 4 on plane row r: vertical pass of the adjoint and grad += scale M (G0 + 2 x' G1 + y G2)
/// at the static pixels. `acc`: 3 W scratch values.
template <typename T>
void addGradientRow(const SsimPlanes<T>& b, int r, T scale, T* grad, T* acc) {
  const int W = b.W, H = b.H;
  const int c = r / H, v = r % H;
  const std::size_t row = static_cast<std::size_t>(r) * W;
  const std::size_t plane = static_cast<std::size_t>(c) * W * H;
  for (int j = 0; j < 3; ++j) convolveColumn(b.h[j] + plane, W, H, v, b.taps, acc + j * W);
  const std::uint8_t* s = b.static_px + static_cast<std::size_t>(v) * W;
  const T* x = b.x + row;
  const T* y = b.y + row;
  for (int u = 0; u < W; ++u) {
    if (!s[u]) continue;
    grad[row + u] += ssim::ssimGradient(scale, acc[u], acc[W + u], acc[2 * W + u], x[u], y[u]);
  }
}

}  // namespace

template <typename T>
SsimLoss<T>::SsimLoss(ThreadPool* pool) : pool_(pool) {
  static_assert(kWindow == ssim::kWindow, "one window");
  const ssim::Taps<T> taps = ssim::windowTaps<T>();
  for (int k = 0; k < kWindow; ++k) taps_[k] = taps.t[k];
}

template <typename T>
void SsimLoss<T>::resize(int width, int height) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  if (x_.size() < 3 * n) {
    x_.resize(3 * n);
    y_.resize(3 * n);
    for (auto& h : h_) h.resize(3 * n);
    for (auto& p : p_) p.resize(3 * n);
    static_.resize(n);
    row_sum_.resize(3 * static_cast<std::size_t>(height));
  }
  if (row_sum_.size() < 3 * static_cast<std::size_t>(height)) row_sum_.resize(3 * static_cast<std::size_t>(height));
  const std::size_t threads = pool_ ? static_cast<std::size_t>(pool_->numThreads()) : 1;
  const std::size_t per_thread = 6 * static_cast<std::size_t>(width + 2 * kRadius);
  if (pad_.size() < threads) pad_.resize(threads);
  for (auto& p : pad_)
    if (p.size() < per_thread) p.resize(per_thread);
  width_ = width;
  height_ = height;
}

template <typename T>
double SsimLoss<T>::compute(const T* rendered, const T* target, const std::uint8_t* static_mask, std::size_t mask_step,
                            int width, int height, T weight, T* grad, T* ssim_map) {
  if (width <= 0 || height <= 0) return 1.0;
  resize(width, height);
  const int W = width, H = height;
  const std::size_t n_static = markStaticPixels(static_mask, mask_step, W, H, static_.data());
  const bool want_grad = grad != nullptr && n_static > 0;
  auto forRows = [&](const auto& fn) {
    if (pool_) {
      pool_->parallelFor(
          3 * H, [&](int r, int thread) { fn(r, thread); }, 4);
    } else {
      for (int r = 0; r < 3 * H; ++r) fn(r, 0);
    }
  };
  const SsimPlanes<T> planes{W,
                             H,
                             taps_,
                             static_.data(),
                             x_.data(),
                             y_.data(),
                             {h_[0].data(), h_[1].data(), h_[2].data(), h_[3].data(), h_[4].data()},
                             {p_[0].data(), p_[1].data(), p_[2].data()}};

  // 1. Composite x' = M x + (1 - M) y; horizontal pass of x', y, x'^2, y^2, x'y.
  forRows([&](int r, int thread) { compositeAndFilterRow(planes, r, rendered, target, pad_[thread].data()); });

  // 2. Vertical pass -> window statistics -> SSIM and the per-pixel derivative terms
  //    P0 = M (dS/dmu_x - 2 mu_x dS/dsxx - mu_y dS/dsxy), P1 = M dS/dsxx, P2 = M dS/dsxy.
  forRows([&](int r, int thread) { row_sum_[r] = ssimRow(planes, r, want_grad, ssim_map, pad_[thread].data()); });
  double total = 0.0;
  for (int r = 0; r < 3 * H; ++r) total += row_sum_[r];
  if (n_static == 0) return 1.0;
  const double n = 3.0 * static_cast<double>(n_static);
  const double mean = total / n;
  if (!want_grad) return mean;

  // 3. Adjoint of the windows (the window is symmetric: the same convolutions), horizontal pass.
  forRows([&](int r, int thread) {
    const std::size_t row = static_cast<std::size_t>(r) * W;
    T* pad = pad_[thread].data();
    for (int j = 0; j < 3; ++j) convolveRow(p_[j].data() + row, W, taps_, pad, h_[j].data() + row);
  });
  // 4. Vertical pass and d(1 - mean SSIM)/dx = -(1/n) M (G0 + 2 x' G1 + y G2).
  const T scale = static_cast<T>(-static_cast<double>(weight) / n);
  forRows([&](int r, int thread) { addGradientRow(planes, r, scale, grad, pad_[thread].data()); });
  return mean;
}

template class SsimLoss<float>;
template class SsimLoss<double>;

}  // namespace dypho::mapping
