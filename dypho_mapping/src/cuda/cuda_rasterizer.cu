/// CudaRasterizer: the GPU forward and backward pass (see cuda_rasterizer.h for the stages). The
/// math is the CPU path's: gaussian_math.h (per Gaussian) and blend_steps.h (per pixel).
#include "dypho/mapping/cuda_rasterizer.h"

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>

#include <stdexcept>
#include <string>

#include "cuda_check.h"
#include "dypho/mapping/blend_steps.h"
#include "kernel_bodies.h"
#include "dypho/mapping/compute_device.h"

namespace dypho::mapping {
namespace {

using Packed = raster::PackedGaussian<float>;
using cuda_body::TilePixel;
using cuda_body::TileRange;
constexpr int S = gs::kTileSize;
constexpr int kThreads = 256;  ///< threads per block of the per-Gaussian kernels
constexpr unsigned kFullWarp = 0xffffffffu;

int blocksFor(std::size_t n) { return static_cast<int>((n + kThreads - 1) / kThreads); }

__global__ void preprocessKernel(GaussianParamsView<float> P, gs::PinholeView<float> cam, float radius_sigma,
                                 float min_alpha, int tiles_x, int tiles_y, Packed* packed,
                                 std::uint32_t* tiles_touched, unsigned int* num_visible) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= P.count) return;
  const std::uint32_t n = cuda_body::preprocess(i, P, cam, radius_sigma, min_alpha, tiles_x, tiles_y, packed);
  tiles_touched[i] = n;
  if (n > 0) atomicAdd(num_visible, 1u);
}

__global__ void emitKeysKernel(int n, const Packed* packed, const std::uint32_t* tiles_touched,
                               const std::uint32_t* offsets_inclusive, int tiles_x, unsigned long long* keys,
                               std::uint32_t* values) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) cuda_body::emitKeys(i, packed, tiles_touched, offsets_inclusive, tiles_x, keys, values);
}

__global__ void tileRangesKernel(std::uint32_t total, const unsigned long long* keys, TileRange* ranges) {
  const std::uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < total) cuda_body::tileRange(k, total, keys, ranges);
}

/// Front-to-back compositing, one thread per pixel, one 16x16 block per tile.
__global__ void __launch_bounds__(S* S)
    forwardKernel(int width, int height, int tiles_x, const TileRange* ranges, const std::uint32_t* values,
                  const Packed* packed, float min_alpha, float min_transmittance, cuda_body::ForwardOut out) {
  const TilePixel t = cuda_body::tilePixel(blockIdx.x, blockIdx.y, threadIdx.x, threadIdx.y, width, height);
  cuda_body::forwardPixel(t, width, height, ranges[blockIdx.y * tiles_x + blockIdx.x], values, packed, min_alpha,
                          min_transmittance, out);
}

__device__ inline float warpSum(float v) {
  for (int offset = 16; offset > 0; offset >>= 1) v += __shfl_down_sync(kFullWarp, v, offset);
  return v;
}
__device__ inline double warpSum(double v) {
  for (int offset = 16; offset > 0; offset >>= 1) v += __shfl_down_sync(kFullWarp, v, offset);
  return v;
}

/// Back-to-front pass, one 16x16 block per tile: the block walks the tile's list in lockstep from
/// the largest last entry of its pixels (as the CPU tile kernel does), each warp sums its pixels'
/// contributions and adds them to the Gaussian's screen gradient.
__global__ void __launch_bounds__(S* S)
    backwardKernel(int width, int height, int tiles_x, const TileRange* ranges, const std::uint32_t* values,
                   const Packed* packed, float min_alpha, const float* final_T, const std::uint32_t* last_entry,
                   const float* grad_color, const float* grad_depth, const float* grad_alpha,
                   gs::ScreenGrad<float>* screen) {
  __shared__ std::uint32_t block_last;
  const TilePixel t = cuda_body::tilePixel(blockIdx.x, blockIdx.y, threadIdx.x, threadIdx.y, width, height);
  const TileRange range = ranges[blockIdx.y * tiles_x + blockIdx.x];
  cuda_body::BackwardStart b =
      cuda_body::backwardStart(t, width, height, range, final_T, last_entry, grad_color, grad_depth, grad_alpha);
  const int lane = (threadIdx.y * S + threadIdx.x) & 31;
  if (threadIdx.x == 0 && threadIdx.y == 0) block_last = range.begin;
  __syncthreads();
  atomicMax(&block_last, b.last);
  __syncthreads();
  for (std::uint32_t k = block_last; k-- > range.begin;) {
    const std::uint32_t gi = values[k];
    gs::ScreenGrad<float> s{};
    const bool touched = cuda_body::backwardPixelStep(t, k, packed[gi], min_alpha, b, s);
    if (!__any_sync(kFullWarp, touched)) continue;
    const float sums[10] = {warpSum(s.mean_u),   warpSum(s.mean_v),  warpSum(s.conic_a),  warpSum(s.conic_b),
                            warpSum(s.conic_c),  warpSum(s.opacity), warpSum(s.color[0]), warpSum(s.color[1]),
                            warpSum(s.color[2]), warpSum(s.depth)};
    if (lane == 0) {
      gs::ScreenGrad<float>& out = screen[gi];
      float* const fields[10] = {&out.mean_u,  &out.mean_v,   &out.conic_a,  &out.conic_b,  &out.conic_c,
                                 &out.opacity, &out.color[0], &out.color[1], &out.color[2], &out.depth};
      for (int f = 0; f < 10; ++f)
        if (sums[f] != 0.f) atomicAdd(fields[f], sums[f]);
    }
  }
}

/// Chain rule per Gaussian; the pose gradient is summed per warp, then in double across warps.
__global__ void chainKernel(GaussianParamsView<float> P, gs::PinholeView<float> cam, const std::uint32_t* tiles_touched,
                            const gs::ScreenGrad<float>* screen, cuda_body::ParamGradsOut out, double* pose) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  float pose_part[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  if (i < P.count) {
    const bool visible = tiles_touched[i] > 0;
    const gs::ScreenGrad<float> sg = visible ? screen[i] : gs::ScreenGrad<float>{};
    cuda_body::chain(i, P, cam, visible, sg, out, pose_part);
  }
  const int lane = threadIdx.x & 31;
  for (int k = 0; k < 6; ++k) {
    const double v = warpSum(static_cast<double>(pose_part[k]));
    if (lane == 0 && v != 0.0) atomicAdd(&pose[k], v);
  }
}

}  // namespace

struct CudaRasterizer::Impl {
  RasterSettings settings;
  cudaStream_t stream = nullptr;
  cudaEvent_t events[6] = {};
  bool forward_timed = false, backward_timed = false;
  RasterStageTimes times;
  GaussianParamsView<float> params{};  ///< device pointers of the last forward
  gs::PinholeView<float> view{};
  int tiles_x = 0, tiles_y = 0;
  std::size_t num_entries = 0, num_visible = 0;
  bool have_forward = false;
  GaussianParamsView<float> uploaded{};  ///< device copies of the last setParams()
  bool have_uploaded = false;
  // Host-API copies of the parameters and pixel gradients.
  cuda::DeviceBuffer<float> up_pos, up_log_scale, up_rot, up_opacity, up_sh, up_gc, up_gd, up_ga;
  // Forward.
  cuda::DeviceBuffer<Packed> packed;
  cuda::DeviceBuffer<std::uint32_t> tiles_touched, offsets, values, values_sorted, last_entry;
  cuda::DeviceBuffer<unsigned long long> keys, keys_sorted;
  cuda::DeviceBuffer<unsigned char> scan_temp, sort_temp;
  cuda::DeviceBuffer<TileRange> ranges;
  cuda::DeviceBuffer<unsigned int> counter;
  cuda::DeviceBuffer<float> color, depth, alpha, final_T;
  // Backward.
  cuda::DeviceBuffer<gs::ScreenGrad<float>> screen;
  cuda::DeviceBuffer<float> g_pos, g_log_scale, g_rot, g_opacity, g_sh, g_norm;
  cuda::DeviceBuffer<double> pose;

  ~Impl() {
    for (cudaEvent_t& e : events)
      if (e != nullptr) cudaEventDestroy(e);
    if (stream != nullptr) cudaStreamDestroy(stream);
  }

  /// Forward stages (forwardOnDevice). Grows the per-Gaussian, per-tile and per-pixel buffers.
  void reserveForward(std::size_t n, std::size_t npix, int num_tiles);
  /// Projects the n Gaussians of `params` into `view` and counts their tile entries (returned, and
  /// kept in num_entries) and the visible ones (num_visible); events 0 and 1 around it.
  std::uint32_t projectAndCount(std::size_t n);
  /// Emits the (tile, depth) keys of the `total` tile entries, sorts them and finds each tile's
  /// range; event 2 after it.
  void binAndSort(std::size_t n, std::uint32_t total, int num_tiles);
  /// Composites every tile of `view` into the output images; event 3 after it.
  void composite();

  float elapsed(int a, int b) const {
    float ms = 0.f;
    DYPHO_CUDA_CHECK(cudaEventElapsedTime(&ms, events[a], events[b]));
    return ms;
  }
};

CudaRasterizer::CudaRasterizer(const RasterSettings& settings) : impl_(std::make_unique<Impl>()) {
  if (!(settings.radius_sigma > 0) || !(settings.min_alpha >= 0) || !(settings.min_transmittance >= 0)) {
    throw std::invalid_argument("CudaRasterizer: radius_sigma must be > 0, min_alpha and min_transmittance >= 0");
  }
  std::string reason;
  if (cudaDeviceCount(&reason) <= 0) throw std::runtime_error("CudaRasterizer: no usable CUDA device: " + reason);
  impl_->settings = settings;
  DYPHO_CUDA_CHECK(cudaStreamCreateWithFlags(&impl_->stream, cudaStreamNonBlocking));
  for (cudaEvent_t& e : impl_->events) DYPHO_CUDA_CHECK(cudaEventCreate(&e));
}

CudaRasterizer::~CudaRasterizer() = default;

void* CudaRasterizer::stream() const { return impl_->stream; }
std::size_t CudaRasterizer::numTileEntries() const { return impl_->num_entries; }
std::size_t CudaRasterizer::numVisible() const { return impl_->num_visible; }
const RasterSettings& CudaRasterizer::settings() const { return impl_->settings; }

const RasterStageTimes& CudaRasterizer::stageTimes() const {
  Impl& m = *impl_;
  if (m.forward_timed) {
    DYPHO_CUDA_CHECK(cudaEventSynchronize(m.events[3]));
    m.times.project_ms = m.elapsed(0, 1);
    m.times.bin_ms = m.elapsed(1, 2);
    m.times.composite_ms = m.elapsed(2, 3);
    m.forward_timed = false;
  }
  if (m.backward_timed) {
    DYPHO_CUDA_CHECK(cudaEventSynchronize(m.events[5]));
    m.times.tiles_back_ms = m.elapsed(3, 4);
    m.times.chain_ms = m.elapsed(4, 5);
    m.backward_timed = false;
  }
  return m.times;
}

namespace {

/// Throws std::invalid_argument for a camera without size or focal length, a negative Gaussian
/// count or an unsupported SH degree.
void checkForwardInputs(const GaussianParamsView<float>& params, const gs::PinholeView<float>& view) {
  if (view.width <= 0 || view.height <= 0 || !(view.fx > 0) || !(view.fy > 0)) {
    throw std::invalid_argument("CudaRasterizer::forward: invalid camera (size and focal lengths must be > 0)");
  }
  if (params.count < 0 || params.sh_degree < 0 || params.sh_degree > gs::kMaxShDegree) {
    throw std::invalid_argument("CudaRasterizer::forward: bad Gaussian count or SH degree");
  }
}

}  // namespace

void CudaRasterizer::Impl::reserveForward(std::size_t n, std::size_t npix, int num_tiles) {
  packed.reserve(n);
  tiles_touched.reserve(n);
  offsets.reserve(n);
  counter.reserve(1);
  ranges.reserve(num_tiles);
  color.reserve(3 * npix);
  depth.reserve(npix);
  alpha.reserve(npix);
  final_T.reserve(npix);
  last_entry.reserve(npix);
}

std::uint32_t CudaRasterizer::Impl::projectAndCount(std::size_t n) {
  cudaStream_t st = stream;
  DYPHO_CUDA_CHECK(cudaEventRecord(events[0], st));
  DYPHO_CUDA_CHECK(cudaMemsetAsync(counter.get(), 0, sizeof(unsigned int), st));
  std::uint32_t total = 0;
  unsigned int visible = 0;
  if (n > 0) {
    preprocessKernel<<<blocksFor(n), kThreads, 0, st>>>(params, view, static_cast<float>(settings.radius_sigma),
                                                        static_cast<float>(settings.min_alpha), tiles_x, tiles_y,
                                                        packed.get(), tiles_touched.get(), counter.get());
    DYPHO_CUDA_CHECK_LAUNCH("preprocessKernel");
    std::size_t temp_bytes = 0;
    DYPHO_CUDA_CHECK(cub::DeviceScan::InclusiveSum(nullptr, temp_bytes, tiles_touched.get(), offsets.get(),
                                                   static_cast<int>(n), st));
    scan_temp.reserve(temp_bytes);
    DYPHO_CUDA_CHECK(cub::DeviceScan::InclusiveSum(scan_temp.get(), temp_bytes, tiles_touched.get(), offsets.get(),
                                                   static_cast<int>(n), st));
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(&total, offsets.get() + n - 1, sizeof(total), cudaMemcpyDeviceToHost, st));
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(&visible, counter.get(), sizeof(visible), cudaMemcpyDeviceToHost, st));
    DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
  }
  num_entries = total;
  num_visible = visible;
  DYPHO_CUDA_CHECK(cudaEventRecord(events[1], st));
  return total;
}

void CudaRasterizer::Impl::binAndSort(std::size_t n, std::uint32_t total, int num_tiles) {
  cudaStream_t st = stream;
  DYPHO_CUDA_CHECK(cudaMemsetAsync(ranges.get(), 0, num_tiles * sizeof(TileRange), st));
  if (total > 0) {
    keys.reserve(total);
    keys_sorted.reserve(total);
    values.reserve(total);
    values_sorted.reserve(total);
    emitKeysKernel<<<blocksFor(n), kThreads, 0, st>>>(static_cast<int>(n), packed.get(), tiles_touched.get(),
                                                      offsets.get(), tiles_x, keys.get(), values.get());
    DYPHO_CUDA_CHECK_LAUNCH("emitKeysKernel");
    int tile_bits = 0;
    while ((1 << tile_bits) < num_tiles) ++tile_bits;
    std::size_t temp_bytes = 0;
    DYPHO_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, temp_bytes, keys.get(), keys_sorted.get(), values.get(),
                                                     values_sorted.get(), static_cast<int>(total), 0, 32 + tile_bits,
                                                     st));
    sort_temp.reserve(temp_bytes);
    DYPHO_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(sort_temp.get(), temp_bytes, keys.get(), keys_sorted.get(),
                                                     values.get(), values_sorted.get(), static_cast<int>(total), 0,
                                                     32 + tile_bits, st));
    tileRangesKernel<<<blocksFor(total), kThreads, 0, st>>>(total, keys_sorted.get(), ranges.get());
    DYPHO_CUDA_CHECK_LAUNCH("tileRangesKernel");
  }
  DYPHO_CUDA_CHECK(cudaEventRecord(events[2], st));
}

void CudaRasterizer::Impl::composite() {
  cudaStream_t st = stream;
  const dim3 grid(tiles_x, tiles_y), block(S, S);
  const cuda_body::ForwardOut out{color.get(), depth.get(), alpha.get(), final_T.get(), last_entry.get()};
  forwardKernel<<<grid, block, 0, st>>>(view.width, view.height, tiles_x, ranges.get(), values_sorted.reserve(1),
                                        packed.get(), static_cast<float>(settings.min_alpha),
                                        static_cast<float>(settings.min_transmittance), out);
  DYPHO_CUDA_CHECK_LAUNCH("forwardKernel");
  DYPHO_CUDA_CHECK(cudaEventRecord(events[3], st));
}

DeviceImages CudaRasterizer::forwardOnDevice(const GaussianParamsView<float>& params,
                                             const gs::PinholeView<float>& view) {
  checkForwardInputs(params, view);
  Impl& m = *impl_;
  m.params = params;
  m.view = view;
  m.tiles_x = (view.width + S - 1) / S;
  m.tiles_y = (view.height + S - 1) / S;
  const int num_tiles = m.tiles_x * m.tiles_y;
  const std::size_t n = static_cast<std::size_t>(params.count);
  const std::size_t npix = static_cast<std::size_t>(view.width) * view.height;
  m.reserveForward(n, npix, num_tiles);
  const std::uint32_t total = m.projectAndCount(n);
  m.binAndSort(n, total, num_tiles);
  m.composite();
  m.forward_timed = true;
  m.have_forward = true;
  DeviceImages images;
  images.width = view.width;
  images.height = view.height;
  images.color = m.color.get();
  images.depth = m.depth.get();
  images.alpha = m.alpha.get();
  return images;
}

DeviceGrads CudaRasterizer::backwardOnDevice(const PixelGrads<float>& grads, float* pose_out) {
  Impl& m = *impl_;
  if (!m.have_forward) throw std::logic_error("CudaRasterizer::backward called before forward");
  cudaStream_t st = m.stream;
  const std::size_t n = static_cast<std::size_t>(m.params.count);
  const int K3 = 3 * gs::shCoeffCount(m.params.sh_degree);
  m.screen.reserve(n);
  m.g_pos.reserve(3 * n);
  m.g_log_scale.reserve(3 * n);
  m.g_rot.reserve(4 * n);
  m.g_opacity.reserve(n);
  m.g_sh.reserve(static_cast<std::size_t>(K3) * n);
  m.g_norm.reserve(n);
  m.pose.reserve(6);
  DYPHO_CUDA_CHECK(cudaMemsetAsync(m.screen.get(), 0, n * sizeof(gs::ScreenGrad<float>), st));
  DYPHO_CUDA_CHECK(cudaMemsetAsync(m.pose.get(), 0, 6 * sizeof(double), st));
  const dim3 grid(m.tiles_x, m.tiles_y), block(S, S);
  backwardKernel<<<grid, block, 0, st>>>(m.view.width, m.view.height, m.tiles_x, m.ranges.get(),
                                         m.values_sorted.reserve(1), m.packed.get(),
                                         static_cast<float>(m.settings.min_alpha), m.final_T.get(), m.last_entry.get(),
                                         grads.color, grads.depth, grads.alpha, m.screen.get());
  DYPHO_CUDA_CHECK_LAUNCH("backwardKernel");
  DYPHO_CUDA_CHECK(cudaEventRecord(m.events[4], st));
  if (n > 0) {
    const cuda_body::ParamGradsOut out{m.g_pos.get(),     m.g_log_scale.get(), m.g_rot.get(),
                                       m.g_opacity.get(), m.g_sh.get(),        m.g_norm.get()};
    chainKernel<<<blocksFor(n), kThreads, 0, st>>>(m.params, m.view, m.tiles_touched.get(), m.screen.get(), out,
                                                   m.pose.get());
    DYPHO_CUDA_CHECK_LAUNCH("chainKernel");
  }
  DYPHO_CUDA_CHECK(cudaEventRecord(m.events[5], st));
  m.backward_timed = true;
  if (pose_out != nullptr) {
    double pose[6];
    DYPHO_CUDA_CHECK(cudaMemcpyAsync(pose, m.pose.get(), sizeof(pose), cudaMemcpyDeviceToHost, st));
    DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
    for (int k = 0; k < 6; ++k) pose_out[k] = static_cast<float>(pose[k]);
  }
  DeviceGrads g;
  g.position = m.g_pos.get();
  g.log_scale = m.g_log_scale.get();
  g.rotation = m.g_rot.get();
  g.opacity_logit = m.g_opacity.get();
  g.sh = m.g_sh.get();
  g.mean2d_norm = m.g_norm.get();
  return g;
}

namespace {

void upload(cuda::DeviceBuffer<float>& dst, const float* src, std::size_t count, cudaStream_t st) {
  float* d = dst.reserve(count);
  if (count > 0) DYPHO_CUDA_CHECK(cudaMemcpyAsync(d, src, count * sizeof(float), cudaMemcpyHostToDevice, st));
}

void download(std::vector<float>& dst, const float* src, std::size_t count, cudaStream_t st) {
  dst.resize(count);
  if (count > 0) DYPHO_CUDA_CHECK(cudaMemcpyAsync(dst.data(), src, count * sizeof(float), cudaMemcpyDeviceToHost, st));
}

}  // namespace

void CudaRasterizer::setParams(const GaussianParamsView<float>& params) {
  Impl& m = *impl_;
  cudaStream_t st = m.stream;
  if (params.count < 0 || params.sh_degree < 0 || params.sh_degree > gs::kMaxShDegree) {
    throw std::invalid_argument("CudaRasterizer::setParams: bad Gaussian count or SH degree");
  }
  const std::size_t n = static_cast<std::size_t>(params.count);
  const std::size_t K3 = 3 * static_cast<std::size_t>(gs::shCoeffCount(params.sh_degree));
  upload(m.up_pos, params.position, 3 * n, st);
  upload(m.up_log_scale, params.log_scale, 3 * n, st);
  upload(m.up_rot, params.rotation, 4 * n, st);
  upload(m.up_opacity, params.opacity_logit, n, st);
  upload(m.up_sh, params.sh, K3 * n, st);
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));  // the host arrays may change after the call
  m.uploaded = params;
  m.uploaded.position = m.up_pos.get();
  m.uploaded.log_scale = m.up_log_scale.get();
  m.uploaded.rotation = m.up_rot.get();
  m.uploaded.opacity_logit = m.up_opacity.get();
  m.uploaded.sh = m.up_sh.get();
  m.have_uploaded = true;
}

void CudaRasterizer::forwardUploaded(const gs::PinholeView<float>& view, RenderResult<float>& out) {
  Impl& m = *impl_;
  if (!m.have_uploaded) throw std::logic_error("CudaRasterizer::forwardUploaded called before setParams");
  cudaStream_t st = m.stream;
  const DeviceImages images = forwardOnDevice(m.uploaded, view);
  const std::size_t npix = static_cast<std::size_t>(images.width) * images.height;
  out.width = images.width;
  out.height = images.height;
  download(out.color, images.color, 3 * npix, st);
  download(out.depth, images.depth, npix, st);
  download(out.alpha, images.alpha, npix, st);
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
}

void CudaRasterizer::forward(const GaussianParamsView<float>& params, const gs::PinholeView<float>& view,
                             RenderResult<float>& out) {
  setParams(params);
  forwardUploaded(view, out);
}

void CudaRasterizer::backward(const PixelGrads<float>& grads, GaussianGrads<float>& out) {
  Impl& m = *impl_;
  cudaStream_t st = m.stream;
  const std::size_t npix = static_cast<std::size_t>(m.view.width) * m.view.height;
  PixelGrads<float> device;
  if (grads.color != nullptr) {
    upload(m.up_gc, grads.color, 3 * npix, st);
    device.color = m.up_gc.get();
  }
  if (grads.depth != nullptr) {
    upload(m.up_gd, grads.depth, npix, st);
    device.depth = m.up_gd.get();
  }
  if (grads.alpha != nullptr) {
    upload(m.up_ga, grads.alpha, npix, st);
    device.alpha = m.up_ga.get();
  }
  const DeviceGrads g = backwardOnDevice(device, out.pose);
  const std::size_t n = static_cast<std::size_t>(m.params.count);
  const std::size_t K3 = 3 * static_cast<std::size_t>(gs::shCoeffCount(m.params.sh_degree));
  download(out.position, g.position, 3 * n, st);
  download(out.log_scale, g.log_scale, 3 * n, st);
  download(out.rotation, g.rotation, 4 * n, st);
  download(out.opacity_logit, g.opacity_logit, n, st);
  download(out.sh, g.sh, K3 * n, st);
  download(out.mean2d_norm, g.mean2d_norm, n, st);
  DYPHO_CUDA_CHECK(cudaStreamSynchronize(st));
}

}  // namespace dypho::mapping
