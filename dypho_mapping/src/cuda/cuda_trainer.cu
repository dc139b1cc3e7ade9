/// CudaTrainer: loss, Adam and statistics kernels, and the device copy of the training state.
#include "dypho/mapping/cuda_trainer.h"

#include <stdexcept>
#include <string>
#include <unordered_map>

#include <cub/device/device_scan.cuh>

#include "cuda_check.h"
#include "dypho/mapping/adam_math.h"
#include "dypho/mapping/ssim_math.h"
#include "kernel_bodies.h"

namespace dypho::mapping {
namespace {

constexpr int kThreads = 256;
constexpr int kWarps = kThreads / 32;
using train::kLossSums;
using train::LossParams;

int blocksFor(std::size_t n) { return static_cast<int>((n + kThreads - 1) / kThreads); }

__device__ inline float warpSum(float v) {
  for (int offset = 16; offset > 0; offset >>= 1) v += __shfl_down_sync(0xffffffffu, v, offset);
  return v;
}

/// Adds the block's sums of the N per-thread values `s` to out[0..N) (float within the block,
/// double across blocks). Every thread of the block must call it.
template <int N>
__device__ void blockSum(const float (&s)[N], double* out) {
  __shared__ float partial[kWarps][N];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  for (int k = 0; k < N; ++k) {
    const float v = warpSum(s[k]);
    if (lane == 0) partial[warp][k] = v;
  }
  __syncthreads();
  if (threadIdx.x < N) {
    double total = 0.0;
    for (int w = 0; w < kWarps; ++w) total += partial[w][threadIdx.x];
    if (total != 0.0) atomicAdd(&out[threadIdx.x], total);
  }
}

/// The loss per pixel (train::l1LossPixel); the block's sums go to `sums` in double.
__global__ void __launch_bounds__(kThreads)
    l1LossKernel(LossParams L, const float* color, const float* depth, const float* alpha, const float* t_rgb,
                 const float* t_depth, const std::uint8_t* mask, float* g_color, float* g_depth, float* g_alpha,
                 double* sums, float* shown) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  float s[kLossSums] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  if (i < L.npix) {
    train::l1LossPixel(i, L, color, depth, alpha, t_rgb, t_depth, mask, g_color, g_depth, g_alpha, s, shown);
  }
  blockSum(s, sums);
}

/// The five window maps' planes (x', y, x'^2, y^2, x'y), then reused for the adjoint pass.
struct Planes5 {
  float* p[5];
};
struct Planes3 {
  float* p[3];
};

__device__ inline void planeIndex(std::size_t i, int width, int height, int& c, int& v, int& u) {
  const std::size_t npix = static_cast<std::size_t>(width) * height;
  c = static_cast<int>(i / npix);
  const std::size_t rem = i % npix;
  v = static_cast<int>(rem / width);
  u = static_cast<int>(rem % width);
}

__global__ void ssimHorizontalKernel(cuda_body::SsimImages im, ssim::Taps<float> taps, Planes5 h) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= 3 * static_cast<std::size_t>(im.width) * im.height) return;
  int c, v, u;
  planeIndex(i, im.width, im.height, c, v, u);
  float out[5];
  cuda_body::ssimHorizontal(im, taps, c, v, u, out);
  for (int j = 0; j < 5; ++j) h.p[j][i] = out[j];
}

/// Window statistics -> SSIM (summed over static pixels into sum[0]) and the backward terms.
__global__ void __launch_bounds__(kThreads)
    ssimVerticalKernel(cuda_body::SsimImages im, ssim::Taps<float> taps, Planes5 h, Planes3 terms, double* sum) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  float s[1] = {0.f};
  if (i < 3 * static_cast<std::size_t>(im.width) * im.height) {
    int c, v, u;
    planeIndex(i, im.width, im.height, c, v, u);
    float acc[5];
    for (int j = 0; j < 5; ++j) acc[j] = cuda_body::verticalAt(h.p[j], taps, c, v, u, im.width, im.height);
    const float m = im.mask[static_cast<std::size_t>(v) * im.width + u] != 0 ? 1.f : 0.f;
    const ssim::PixelSsim<float> px = ssim::pixelSsim(acc[0], acc[1], acc[2], acc[3], acc[4], m);
    terms.p[0][i] = px.p0;
    terms.p[1][i] = px.p1;
    terms.p[2][i] = px.p2;
    s[0] = m * px.S;
  }
  blockSum(s, sum);
}

/// Adjoint of the window (symmetric: the same filter), horizontal pass of the three terms.
__global__ void ssimAdjointHorizontalKernel(int width, int height, ssim::Taps<float> taps, Planes3 terms, Planes5 h) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= 3 * static_cast<std::size_t>(width) * height) return;
  int c, v, u;
  planeIndex(i, width, height, c, v, u);
  for (int j = 0; j < 3; ++j) h.p[j][i] = cuda_body::horizontalAt(terms.p[j], taps, c, v, u, width, height);
}

/// Vertical adjoint pass and the gradient at static pixels, added to the colour gradient.
__global__ void ssimGradientKernel(cuda_body::SsimImages im, ssim::Taps<float> taps, Planes5 h, float scale,
                                   float* g_color) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= 3 * static_cast<std::size_t>(im.width) * im.height) return;
  int c, v, u;
  planeIndex(i, im.width, im.height, c, v, u);
  if (im.mask[static_cast<std::size_t>(v) * im.width + u] == 0) return;
  float G[3];
  for (int j = 0; j < 3; ++j) G[j] = cuda_body::verticalAt(h.p[j], taps, c, v, u, im.width, im.height);
  float x, y;
  cuda_body::ssimXY(im, c, v, u, x, y);
  g_color[i] += ssim::ssimGradient(scale, G[0], G[1], G[2], x, y);
}

__global__ void __launch_bounds__(kThreads)
    exposureChainKernel(LossParams L, const float* shown, float* g_color, double* sums) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  float s[kLossSums] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  if (i < L.npix) train::exposureChain(i, L, shown, g_color, s);
  blockSum(s, sums);
}

__global__ void adamKernel(std::size_t total, int width, int block, AdamStepSizes step, const float* grad, float* x,
                           float* m, float* v) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < total) cuda_body::adam(i, width, block == 4, step, block, grad, x, m, v);
}

__global__ void isotropyKernel(std::size_t n, const float* log_scale, const float* norm, float weight, float* grad) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) cuda_body::isotropy(i, log_scale, norm, weight, grad);
}

__global__ void statisticsKernel(std::size_t n, const float* norm, float* accum, int* count) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) cuda_body::statistics(i, norm, accum, count);
}

__global__ void densifyDecideKernel(std::size_t n, const float* accum, const int* count, const float* log_scale,
                                    DensifySettings s, std::uint32_t* children) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) children[i] = cuda_body::densifyChildren(i, accum, count, log_scale, s);
}

/// Children of Gaussian i into rows n0 + offset (those that fit under `added`); marks a split
/// parent whose both halves fit.
__global__ void spawnKernel(std::size_t n0, const std::uint32_t* children, const std::uint32_t* offsets,
                            std::uint32_t added, cuda_body::StateBlocks b, std::uint32_t seed, std::uint32_t* parents,
                            std::uint8_t* split_done) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n0) return;
  const std::uint32_t c = children[i], off = offsets[i];
  for (std::uint32_t k = 0; k < c && off + k < added; ++k) {
    cuda_body::spawnChild(i, k, c == 2, n0 + off + k, b, seed);
    parents[off + k] = static_cast<std::uint32_t>(i);
  }
  split_done[i] = c == 2 && off + 1 < added ? 1 : 0;
}

__global__ void pruneKernel(std::size_t n1, std::size_t n0, const std::uint8_t* split_done, cuda_body::StateBlocks b,
                            DensifySettings s, std::uint8_t* remove, std::uint32_t* keep) {
  const std::size_t r = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r >= n1) return;
  const bool gone = cuda_body::pruned(r, r < n0 && split_done[r] != 0, b, s);
  remove[r] = gone ? 1 : 0;
  keep[r] = gone ? 0 : 1;
}

__global__ void compactKernel(std::size_t n1, const std::uint8_t* remove, const std::uint32_t* keep_offsets,
                              cuda_body::StateBlocks src, cuda_body::StateBlocks dst) {
  const std::size_t r = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r < n1 && remove[r] == 0) cuda_body::moveRow(r, keep_offsets[r], src, dst);
}

struct Target {
  int width = 0, height = 0;
  std::size_t static_pixels = 0, depth_pixels = 0;  ///< nc, nd of the loss
  cuda::DeviceBuffer<float> rgb, depth;
  cuda::DeviceBuffer<std::uint8_t> mask;
};

}  // namespace

struct CudaTrainer::Impl {
  explicit Impl(const RasterSettings& settings) : raster(settings) {}
  CudaRasterizer raster;
  cudaStream_t stream() const { return static_cast<cudaStream_t>(raster.stream()); }
  std::size_t count = 0;
  int sh_degree = 0;
  int widths[kTrainingBlocks] = {0, 0, 0, 0, 0};
  cuda::DeviceBuffer<float> params[kTrainingBlocks], m[kTrainingBlocks], v[kTrainingBlocks];
  cuda::DeviceBuffer<float> accum;
  cuda::DeviceBuffer<int> grad_count;
  std::unordered_map<std::int64_t, std::unique_ptr<Target>> targets;
  cuda::DeviceBuffer<float> g_color, g_depth, g_alpha;
  cuda::DeviceBuffer<double> sums;
  DeviceImages last{};
  // SSIM term.
  ssim::Taps<float> taps = ssim::windowTaps<float>();
  cuda::DeviceBuffer<float> shown, ssim_h[5], ssim_terms[3];
  // Densify and prune scratch (grow-only); params2/m2/v2 receive the compacted rows.
  cuda::DeviceBuffer<float> params2[kTrainingBlocks], m2[kTrainingBlocks], v2[kTrainingBlocks];
  cuda::DeviceBuffer<std::uint32_t> children, child_offsets, parents, keep, keep_offsets;
  cuda::DeviceBuffer<std::uint8_t> split_done, remove, scan_temp;

  cuda_body::StateBlocks blocks(bool second) {
    cuda_body::StateBlocks b{};
    for (int p = 0; p < kTrainingBlocks; ++p) {
      b.params[p] = second ? params2[p].get() : params[p].get();
      b.m[p] = second ? m2[p].get() : m[p].get();
      b.v[p] = second ? v2[p].get() : v[p].get();
      b.widths[p] = widths[p];
    }
    return b;
  }

  /// Exclusive prefix sum of n values; returns the sum of all n (read back).
  std::uint32_t exclusiveScan(const std::uint32_t* in, std::uint32_t* out, std::size_t n) {
    cudaStream_t st = stream();
    std::size_t bytes = 0;
    DYPHO_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in, out, static_cast<int>(n), st));
    scan_temp.reserve(bytes);
    DYPHO_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(scan_temp.get(), bytes, in, out, static_cast<int>(n), st));
    std::uint32_t last_in = 0, last_out = 0;
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(&last_in, in + n - 1, sizeof(last_in), cudaMemcpyDeviceToHost, st));
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(&last_out, out + n - 1, sizeof(last_out), cudaMemcpyDeviceToHost, st));
    DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
    return last_in + last_out;
  }
};

CudaTrainer::CudaTrainer(const RasterSettings& settings) : impl_(std::make_unique<Impl>(settings)) {}
CudaTrainer::~CudaTrainer() = default;

CudaRasterizer& CudaTrainer::rasterizer() { return impl_->raster; }
std::size_t CudaTrainer::size() const { return impl_->count; }

void CudaTrainer::upload(const TrainingStateView& host) {
  Impl& d = *impl_;
  cudaStream_t st = d.stream();
  const std::size_t n = host.count;
  for (int p = 0; p < kTrainingBlocks; ++p) {
    const std::size_t values = n * static_cast<std::size_t>(host.widths[p]);
    float* dst[3] = {d.params[p].reserve(values), d.m[p].reserve(values), d.v[p].reserve(values)};
    const float* src[3] = {host.params[p], host.first_moment[p], host.second_moment[p]};
    for (int k = 0; k < 3; ++k)
      if (values > 0)
        DYPHO_CUDA_CHECK(cudaMemcpyAsync(dst[k], src[k], values * sizeof(float), cudaMemcpyHostToDevice, st));
    d.widths[p] = host.widths[p];
  }
  d.accum.reserve(n);
  d.grad_count.reserve(n);
  if (n > 0) {
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(d.accum.get(), host.grad_accum, n * sizeof(float), cudaMemcpyHostToDevice, st));
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(d.grad_count.get(), host.grad_count, n * sizeof(int), cudaMemcpyHostToDevice, st));
  }
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));  // the host arrays may change after the call
  d.count = n;
  d.sh_degree = host.sh_degree;
}

void CudaTrainer::download(const TrainingStateView& host) {
  Impl& d = *impl_;
  if (host.count != d.count || host.sh_degree != d.sh_degree) {
    throw std::invalid_argument("CudaTrainer::download: host arrays hold " + std::to_string(host.count) +
                                " Gaussians, the device " + std::to_string(d.count));
  }
  cudaStream_t st = d.stream();
  const std::size_t n = d.count;
  for (int p = 0; p < kTrainingBlocks; ++p) {
    if (host.widths[p] != d.widths[p]) throw std::invalid_argument("CudaTrainer::download: block widths differ");
    const std::size_t values = n * static_cast<std::size_t>(d.widths[p]);
    const float* src[3] = {d.params[p].get(), d.m[p].get(), d.v[p].get()};
    float* dst[3] = {host.params[p], host.first_moment[p], host.second_moment[p]};
    for (int k = 0; k < 3; ++k)
      if (values > 0)
        DYPHO_CUDA_CHECK(cudaMemcpyAsync(dst[k], src[k], values * sizeof(float), cudaMemcpyDeviceToHost, st));
  }
  if (n > 0) {
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(host.grad_accum, d.accum.get(), n * sizeof(float), cudaMemcpyDeviceToHost, st));
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(host.grad_count, d.grad_count.get(), n * sizeof(int), cudaMemcpyDeviceToHost, st));
  }
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
}

void CudaTrainer::setTarget(std::int64_t id, int width, int height, const float* rgb, const float* depth_m,
                            const std::uint8_t* static_mask) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("CudaTrainer::setTarget: empty image");
  Impl& d = *impl_;
  std::unique_ptr<Target>& t = d.targets[id];
  if (!t) t = std::make_unique<Target>();
  const std::size_t npix = static_cast<std::size_t>(width) * height;
  t->width = width;
  t->height = height;
  t->static_pixels = t->depth_pixels = 0;
  for (std::size_t i = 0; i < npix; ++i) {
    if (static_mask[i] == 0) continue;
    ++t->static_pixels;
    if (depth_m[i] > 0.f) ++t->depth_pixels;
  }
  cudaStream_t st = d.stream();
  DYPHO_CUDA_CHECK(
      cudaMemcpyAsync(t->rgb.reserve(3 * npix), rgb, 3 * npix * sizeof(float), cudaMemcpyHostToDevice, st));
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(t->depth.reserve(npix), depth_m, npix * sizeof(float), cudaMemcpyHostToDevice, st));
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(t->mask.reserve(npix), static_mask, npix, cudaMemcpyHostToDevice, st));
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
}

bool CudaTrainer::hasTarget(std::int64_t id) const { return impl_->targets.count(id) > 0; }
void CudaTrainer::dropTarget(std::int64_t id) { impl_->targets.erase(id); }
void CudaTrainer::clearTargets() { impl_->targets.clear(); }

DeviceImages CudaTrainer::render(const gs::PinholeView<float>& view) {
  Impl& d = *impl_;
  GaussianParamsView<float> p;
  p.position = d.params[0].get();
  p.log_scale = d.params[1].get();
  p.rotation = d.params[2].get();
  p.opacity_logit = d.params[3].get();
  p.sh = d.params[4].get();
  p.count = static_cast<int>(d.count);
  p.sh_degree = d.sh_degree;
  d.last = d.raster.forwardOnDevice(p, view);
  return d.last;
}

void CudaTrainer::downloadRender(RenderResult<float>& out) {
  Impl& d = *impl_;
  cudaStream_t st = d.stream();
  const std::size_t npix = static_cast<std::size_t>(d.last.width) * d.last.height;
  out.width = d.last.width;
  out.height = d.last.height;
  out.color.resize(3 * npix);
  out.depth.resize(npix);
  out.alpha.resize(npix);
  DYPHO_CUDA_CHECK(
      cudaMemcpyAsync(out.color.data(), d.last.color, 3 * npix * sizeof(float), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(out.depth.data(), d.last.depth, npix * sizeof(float), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(out.alpha.data(), d.last.alpha, npix * sizeof(float), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
}

CudaLossResult CudaTrainer::loss(std::int64_t id, double lambda_depth, double alpha_weight, double ssim_weight,
                                 const float* exposure) {
  Impl& d = *impl_;
  const auto it = d.targets.find(id);
  if (it == d.targets.end()) throw std::invalid_argument("CudaTrainer::loss: no target " + std::to_string(id));
  const Target& t = *it->second;
  if (t.width != d.last.width || t.height != d.last.height) {
    throw std::invalid_argument("CudaTrainer::loss: target and render sizes differ");
  }
  cudaStream_t st = d.stream();
  const std::size_t npix = static_cast<std::size_t>(t.width) * t.height;
  d.g_color.reserve(3 * npix);
  d.g_depth.reserve(npix);
  d.g_alpha.reserve(npix);
  constexpr int kSums = kLossSums + 1;  // + the SSIM sum
  d.sums.reserve(kSums);
  CudaLossResult result;
  const double nc = static_cast<double>(t.static_pixels);
  const bool with_ssim = ssim_weight > 0.0 && nc > 0;
  const LossParams L =
      train::lossParams(npix, t.static_pixels, t.depth_pixels, lambda_depth, alpha_weight, exposure, with_ssim);
  float* shown = with_ssim ? d.shown.reserve(3 * npix) : nullptr;
  DYPHO_CUDA_CHECK(cudaMemsetAsync(d.sums.get(), 0, kSums * sizeof(double), st));
  l1LossKernel<<<blocksFor(npix), kThreads, 0, st>>>(L, d.last.color, d.last.depth, d.last.alpha, t.rgb.get(),
                                                     t.depth.get(), t.mask.get(), d.g_color.get(), d.g_depth.get(),
                                                     d.g_alpha.get(), d.sums.get(), shown);
  DYPHO_CUDA_CHECK_LAUNCH("l1LossKernel");
  if (with_ssim) {
    // + w (1 - mean SSIM) over static pixels (SsimLoss's passes), then the exposure's chain rule.
    const std::size_t values = 3 * npix;
    Planes5 h{};
    Planes3 terms{};
    for (int j = 0; j < 5; ++j) h.p[j] = d.ssim_h[j].reserve(values);
    for (int j = 0; j < 3; ++j) terms.p[j] = d.ssim_terms[j].reserve(values);
    const cuda_body::SsimImages im{shown, t.rgb.get(), t.mask.get(), t.width, t.height};
    ssimHorizontalKernel<<<blocksFor(values), kThreads, 0, st>>>(im, d.taps, h);
    DYPHO_CUDA_CHECK_LAUNCH("ssimHorizontalKernel");
    ssimVerticalKernel<<<blocksFor(values), kThreads, 0, st>>>(im, d.taps, h, terms, d.sums.get() + kLossSums);
    DYPHO_CUDA_CHECK_LAUNCH("ssimVerticalKernel");
    ssimAdjointHorizontalKernel<<<blocksFor(values), kThreads, 0, st>>>(t.width, t.height, d.taps, terms, h);
    DYPHO_CUDA_CHECK_LAUNCH("ssimAdjointHorizontalKernel");
    const float scale = static_cast<float>(-ssim_weight / (3.0 * nc));
    ssimGradientKernel<<<blocksFor(values), kThreads, 0, st>>>(im, d.taps, h, scale, d.g_color.get());
    DYPHO_CUDA_CHECK_LAUNCH("ssimGradientKernel");
    if (L.defer_exposure) {
      exposureChainKernel<<<blocksFor(npix), kThreads, 0, st>>>(L, shown, d.g_color.get(), d.sums.get());
      DYPHO_CUDA_CHECK_LAUNCH("exposureChainKernel");
    }
  }
  double sums[kSums];
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(sums, d.sums.get(), sizeof(sums), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
  if (nc == 0) return result;
  result.loss = train::lossFromSums(sums, t.static_pixels, t.depth_pixels, lambda_depth, alpha_weight);
  if (with_ssim) result.loss += ssim_weight * (1.0 - sums[kLossSums] / (3.0 * nc));
  if (exposure != nullptr)
    for (int k = 0; k < 6; ++k) result.exposure_grad[k] = static_cast<float>(sums[3 + k]);
  return result;
}

void CudaTrainer::setPixelGrads(const float* color, const float* depth, const float* alpha) {
  Impl& d = *impl_;
  cudaStream_t st = d.stream();
  const std::size_t npix = static_cast<std::size_t>(d.last.width) * d.last.height;
  const float* src[3] = {color, depth, alpha};
  float* dst[3] = {d.g_color.reserve(3 * npix), d.g_depth.reserve(npix), d.g_alpha.reserve(npix)};
  const std::size_t sizes[3] = {3 * npix, npix, npix};
  for (int k = 0; k < 3; ++k) {
    if (src[k] != nullptr) {
      DYPHO_CUDA_CHECK(cudaMemcpyAsync(dst[k], src[k], sizes[k] * sizeof(float), cudaMemcpyHostToDevice, st));
    } else {
      DYPHO_CUDA_CHECK(cudaMemsetAsync(dst[k], 0, sizes[k] * sizeof(float), st));
    }
  }
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
}

void CudaTrainer::backwardAndStep(const AdamStepSizes& step, float* pose_grad, float isotropy_weight) {
  Impl& d = *impl_;
  cudaStream_t st = d.stream();
  PixelGrads<float> pixel;
  pixel.color = d.g_color.get();
  pixel.depth = d.g_depth.get();
  pixel.alpha = d.g_alpha.get();
  const DeviceGrads g = d.raster.backwardOnDevice(pixel, pose_grad);
  if (isotropy_weight > 0.f && d.count > 0) {
    // The rasterizer's gradient buffer, owned by this trainer's rasterizer until the next backward.
    isotropyKernel<<<blocksFor(d.count), kThreads, 0, st>>>(d.count, d.params[1].get(), g.mean2d_norm,
                                                            isotropy_weight / static_cast<float>(d.count),
                                                            const_cast<float*>(g.log_scale));
    DYPHO_CUDA_CHECK_LAUNCH("isotropyKernel");
  }
  const float* grads[kTrainingBlocks] = {g.position, g.log_scale, g.rotation, g.opacity_logit, g.sh};
  for (int p = 0; p < kTrainingBlocks; ++p) {
    const std::size_t total = d.count * static_cast<std::size_t>(d.widths[p]);
    if (total == 0) continue;
    adamKernel<<<blocksFor(total), kThreads, 0, st>>>(total, d.widths[p], p, step, grads[p], d.params[p].get(),
                                                      d.m[p].get(), d.v[p].get());
    DYPHO_CUDA_CHECK_LAUNCH("adamKernel");
  }
  if (d.count > 0) {
    statisticsKernel<<<blocksFor(d.count), kThreads, 0, st>>>(d.count, g.mean2d_norm, d.accum.get(),
                                                              d.grad_count.get());
    DYPHO_CUDA_CHECK_LAUNCH("statisticsKernel");
  }
}

DensifyOutcome CudaTrainer::densifyAndPrune(const DensifySettings& settings, std::size_t capacity) {
  Impl& d = *impl_;
  cudaStream_t st = d.stream();
  DensifyOutcome out;
  const std::size_t n0 = d.count;
  if (n0 == 0) return out;
  // 1. Children per Gaussian, their rows (exclusive scan), how many fit.
  d.children.reserve(n0);
  d.child_offsets.reserve(n0);
  densifyDecideKernel<<<blocksFor(n0), kThreads, 0, st>>>(n0, d.accum.get(), d.grad_count.get(), d.params[1].get(),
                                                          settings, d.children.get());
  DYPHO_CUDA_CHECK_LAUNCH("densifyDecideKernel");
  const std::size_t wanted = d.exclusiveScan(d.children.get(), d.child_offsets.get(), n0);
  const std::size_t room = capacity > n0 ? capacity - n0 : 0;
  const std::size_t added = wanted < room ? wanted : room;
  out.capacity_hit = wanted > room;
  const std::size_t n1 = n0 + added;
  // 2. Append the children (the blocks grow keeping the first n0 rows).
  for (int p = 0; p < kTrainingBlocks; ++p) {
    const std::size_t w = static_cast<std::size_t>(d.widths[p]);
    d.params[p].reserveKeep(n1 * w, n0 * w, st);
    d.m[p].reserveKeep(n1 * w, n0 * w, st);
    d.v[p].reserveKeep(n1 * w, n0 * w, st);
  }
  d.parents.reserve(added > 0 ? added : 1);
  d.split_done.reserve(n0);
  spawnKernel<<<blocksFor(n0), kThreads, 0, st>>>(n0, d.children.get(), d.child_offsets.get(),
                                                  static_cast<std::uint32_t>(added), d.blocks(false), settings.seed,
                                                  d.parents.get(), d.split_done.get());
  DYPHO_CUDA_CHECK_LAUNCH("spawnKernel");
  // 3. Prune flags over old and new rows, then compact into the second blocks and swap.
  d.remove.reserve(n1);
  d.keep.reserve(n1);
  d.keep_offsets.reserve(n1);
  pruneKernel<<<blocksFor(n1), kThreads, 0, st>>>(n1, n0, d.split_done.get(), d.blocks(false), settings, d.remove.get(),
                                                  d.keep.get());
  DYPHO_CUDA_CHECK_LAUNCH("pruneKernel");
  const std::size_t kept = d.exclusiveScan(d.keep.get(), d.keep_offsets.get(), n1);
  for (int p = 0; p < kTrainingBlocks; ++p) {
    const std::size_t w = static_cast<std::size_t>(d.widths[p]);
    d.params2[p].reserve(kept * w);
    d.m2[p].reserve(kept * w);
    d.v2[p].reserve(kept * w);
  }
  compactKernel<<<blocksFor(n1), kThreads, 0, st>>>(n1, d.remove.get(), d.keep_offsets.get(), d.blocks(false),
                                                    d.blocks(true));
  DYPHO_CUDA_CHECK_LAUNCH("compactKernel");
  for (int p = 0; p < kTrainingBlocks; ++p) {
    d.params[p].swap(d.params2[p]);
    d.m[p].swap(d.m2[p]);
    d.v[p].swap(d.v2[p]);
  }
  // 4. Statistics start over; the host gets what it needs for its ids and anchors.
  d.accum.reserve(kept);
  d.grad_count.reserve(kept);
  if (kept > 0) {
    DYPHO_CUDA_CHECK(cudaMemsetAsync(d.accum.get(), 0, kept * sizeof(float), st));
    DYPHO_CUDA_CHECK(cudaMemsetAsync(d.grad_count.get(), 0, kept * sizeof(int), st));
  }
  out.parents.resize(added);
  out.remove.resize(n1);
  if (added > 0) {
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(out.parents.data(), d.parents.get(), added * sizeof(std::uint32_t),
                                     cudaMemcpyDeviceToHost, st));
  }
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(out.remove.data(), d.remove.get(), n1, cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
  d.count = kept;
  return out;
}

}  // namespace dypho::mapping
