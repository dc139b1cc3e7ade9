/// CudaTrainer: loss, Adam and statistics kernels, and the device copy of the training state.
#include "dypho/mapping/cuda_trainer.h"

#include <stdexcept>
#include <string>
#include <unordered_map>

#include "cuda_check.h"
#include "dypho/mapping/adam_math.h"
#include "kernel_bodies.h"

namespace dypho::mapping {
namespace {

constexpr int kThreads = 256;
constexpr int kWarps = kThreads / 32;
using cuda_body::kLossSums;
using cuda_body::LossParams;

int blocksFor(std::size_t n) { return static_cast<int>((n + kThreads - 1) / kThreads); }

__device__ inline float warpSum(float v) {
  for (int offset = 16; offset > 0; offset >>= 1) v += __shfl_down_sync(0xffffffffu, v, offset);
  return v;
}

/// The loss per pixel (cuda_body::l1LossPixel); the block's sums go to `sums` in double.
__global__ void __launch_bounds__(kThreads) l1LossKernel(LossParams L, const float* color, const float* depth,
                                                         const float* alpha, const float* t_rgb, const float* t_depth,
                                                         const std::uint8_t* mask, float* g_color, float* g_depth,
                                                         float* g_alpha, double* sums) {
  __shared__ float partial[kWarps][kLossSums];
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  float s[kLossSums] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  if (i < L.npix) cuda_body::l1LossPixel(i, L, color, depth, alpha, t_rgb, t_depth, mask, g_color, g_depth, g_alpha, s);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  for (int k = 0; k < kLossSums; ++k) {
    const float v = warpSum(s[k]);
    if (lane == 0) partial[warp][k] = v;
  }
  __syncthreads();
  if (threadIdx.x < kLossSums) {
    double total = 0.0;
    for (int w = 0; w < kWarps; ++w) total += partial[w][threadIdx.x];
    if (total != 0.0) atomicAdd(&sums[threadIdx.x], total);
  }
}

__global__ void adamKernel(std::size_t total, int width, int block, AdamStepSizes step, const float* grad, float* x,
                           float* m, float* v) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < total) cuda_body::adam(i, width, block == 4, step, block, grad, x, m, v);
}

__global__ void statisticsKernel(std::size_t n, const float* norm, float* accum, int* count) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) cuda_body::statistics(i, norm, accum, count);
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
      if (values > 0) DYPHO_CUDA_CHECK(cudaMemcpyAsync(dst[k], src[k], values * sizeof(float), cudaMemcpyHostToDevice, st));
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
      if (values > 0) DYPHO_CUDA_CHECK(cudaMemcpyAsync(dst[k], src[k], values * sizeof(float), cudaMemcpyDeviceToHost, st));
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
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(t->rgb.reserve(3 * npix), rgb, 3 * npix * sizeof(float), cudaMemcpyHostToDevice, st));
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
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(out.color.data(), d.last.color, 3 * npix * sizeof(float), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(out.depth.data(), d.last.depth, npix * sizeof(float), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(out.alpha.data(), d.last.alpha, npix * sizeof(float), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
}

CudaLossResult CudaTrainer::l1Loss(std::int64_t id, double lambda_depth, double alpha_weight, const float* exposure) {
  Impl& d = *impl_;
  const auto it = d.targets.find(id);
  if (it == d.targets.end()) throw std::invalid_argument("CudaTrainer::l1Loss: no target " + std::to_string(id));
  const Target& t = *it->second;
  if (t.width != d.last.width || t.height != d.last.height) {
    throw std::invalid_argument("CudaTrainer::l1Loss: target and render sizes differ");
  }
  cudaStream_t st = d.stream();
  const std::size_t npix = static_cast<std::size_t>(t.width) * t.height;
  d.g_color.reserve(3 * npix);
  d.g_depth.reserve(npix);
  d.g_alpha.reserve(npix);
  d.sums.reserve(kLossSums);
  CudaLossResult result;
  const double nc = static_cast<double>(t.static_pixels), nd = static_cast<double>(t.depth_pixels);
  LossParams L{};
  L.npix = static_cast<int>(npix);
  L.wc = nc > 0 ? static_cast<float>((1.0 - lambda_depth) / (3.0 * nc)) : 0.f;
  L.wd = nd > 0 ? static_cast<float>(lambda_depth / nd) : 0.f;
  L.wa = nd > 0 ? static_cast<float>(alpha_weight / nd) : 0.f;
  L.exposure = exposure != nullptr ? 1 : 0;
  for (int ch = 0; ch < 3; ++ch) {
    L.gain[ch] = exposure != nullptr ? std::exp(exposure[ch]) : 1.f;
    L.offset[ch] = exposure != nullptr ? exposure[3 + ch] : 0.f;
  }
  DYPHO_CUDA_CHECK(cudaMemsetAsync(d.sums.get(), 0, kLossSums * sizeof(double), st));
  l1LossKernel<<<blocksFor(npix), kThreads, 0, st>>>(L, d.last.color, d.last.depth, d.last.alpha, t.rgb.get(),
                                                     t.depth.get(), t.mask.get(), d.g_color.get(), d.g_depth.get(),
                                                     d.g_alpha.get(), d.sums.get());
  DYPHO_CUDA_CHECK_LAUNCH("l1LossKernel");
  double sums[kLossSums];
  DYPHO_CUDA_CHECK(cudaMemcpyAsync(sums, d.sums.get(), sizeof(sums), cudaMemcpyDeviceToHost, st));
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
  if (nc == 0) return result;
  result.loss = (1.0 - lambda_depth) * sums[0] / (3.0 * nc) +
                (nd > 0 ? (lambda_depth * sums[1] + alpha_weight * sums[2]) / nd : 0.0);
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

void CudaTrainer::backwardAndStep(const AdamStepSizes& step) {
  Impl& d = *impl_;
  cudaStream_t st = d.stream();
  PixelGrads<float> pixel;
  pixel.color = d.g_color.get();
  pixel.depth = d.g_depth.get();
  pixel.alpha = d.g_alpha.get();
  const DeviceGrads g = d.raster.backwardOnDevice(pixel);
  const float* grads[kTrainingBlocks] = {g.position, g.log_scale, g.rotation, g.opacity_logit, g.sh};
  for (int p = 0; p < kTrainingBlocks; ++p) {
    const std::size_t total = d.count * static_cast<std::size_t>(d.widths[p]);
    if (total == 0) continue;
    adamKernel<<<blocksFor(total), kThreads, 0, st>>>(total, d.widths[p], p, step, grads[p], d.params[p].get(),
                                                      d.m[p].get(), d.v[p].get());
    DYPHO_CUDA_CHECK_LAUNCH("adamKernel");
  }
  if (d.count > 0) {
    statisticsKernel<<<blocksFor(d.count), kThreads, 0, st>>>(d.count, g.mean2d_norm, d.accum.get(), d.grad_count.get());
    DYPHO_CUDA_CHECK_LAUNCH("statisticsKernel");
  }
}

}  // namespace dypho::mapping
