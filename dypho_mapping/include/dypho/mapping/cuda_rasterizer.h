#pragma once
/// \file cuda_rasterizer.h
/// CUDA tile rasterizer of 3D Gaussians: the same forward and backward pass as Rasterizer<float>
/// (rasterizer.h), on the GPU. The per-Gaussian math (gaussian_math.h) and the per-pixel blending
/// steps (blend_steps.h) are the CPU path's own functions compiled by nvcc; per pixel, Gaussians
/// are composited in the same order (tile lists sorted by depth, ties by index), so images agree
/// to float rounding and gradients to the order of the sums.
///
/// Stages (src/cuda/cuda_rasterizer.cu): preprocess (cull, project, pack; one thread per Gaussian)
/// -> tile binning (keys tile << 32 | depth bits, CUB device radix sort, tile ranges) -> forward
/// (one thread per pixel, one block per 16x16 tile) -> backward (one block per tile walking its
/// list back to front in lockstep, warp sums then atomics per Gaussian) -> chain rule (one thread
/// per Gaussian; pose gradient summed in double). Buffers only grow; no allocation per call once
/// sizes are reached. Every CUDA call is checked: failures throw std::runtime_error naming the call.
///
/// Header free of CUDA types: it compiles in every build. Without CUDA (builtWithCuda() false) or
/// without a device, the constructor throws std::runtime_error saying why.

#include <cstddef>
#include <cstdint>
#include <memory>

#include "dypho/mapping/raster_types.h"

namespace dypho::mapping {

/// Images of the last forward in device memory (planar, row-major; valid until the next forward).
struct DeviceImages {
  int width = 0, height = 0;
  const float* color = nullptr;  ///< [3, H, W]
  const float* depth = nullptr;  ///< [H, W]
  const float* alpha = nullptr;  ///< [H, W]
};

/// Gradients of the last backward in device memory (layout of GaussianParamsView; valid until the
/// next backward).
struct DeviceGrads {
  const float* position = nullptr;
  const float* log_scale = nullptr;
  const float* rotation = nullptr;
  const float* opacity_logit = nullptr;
  const float* sh = nullptr;
  const float* mean2d_norm = nullptr;  ///< [N] |dL/d(mean_u, mean_v)|
};

class CudaRasterizer {
 public:
  /// Uses the current CUDA device and its own stream. Throws std::runtime_error when this build
  /// has no CUDA or no device is usable, std::invalid_argument for bad settings.
  explicit CudaRasterizer(const RasterSettings& settings = RasterSettings());
  ~CudaRasterizer();
  CudaRasterizer(const CudaRasterizer&) = delete;
  CudaRasterizer& operator=(const CudaRasterizer&) = delete;

  /// Host arrays in, host images out (copies both ways): the drop-in for Rasterizer<float>.
  /// Remembers the view for the next backward(); the parameters are copied, so the host arrays
  /// may change after the call.
  void forward(const GaussianParamsView<float>& params, const gs::PinholeView<float>& view, RenderResult<float>& out);
  /// Uploads host parameters for forwardUploaded() (they stay on the device until the next
  /// setParams or forward): renders of one map from many poses upload it once.
  void setParams(const GaussianParamsView<float>& params);
  /// forward() of the parameters of the last setParams() (or forward()).
  void forwardUploaded(const gs::PinholeView<float>& view, RenderResult<float>& out);
  /// Host pixel gradients in (null = zero), host parameter gradients out.
  void backward(const PixelGrads<float>& grads, GaussianGrads<float>& out);

  /// Device arrays in and out (training; no copy of the parameters or the images). `params`
  /// points into device memory and must stay unchanged until the matching backwardOnDevice().
  DeviceImages forwardOnDevice(const GaussianParamsView<float>& params, const gs::PinholeView<float>& view);
  /// `grads` points into device memory ([3, H, W], [H, W], [H, W]; null = zero). The pose
  /// gradient is copied to the host into `pose` (6 values, GaussianGrads::pose) when not null.
  DeviceGrads backwardOnDevice(const PixelGrads<float>& grads, float* pose = nullptr);

  /// (Gaussian, tile) pairs of the last forward.
  std::size_t numTileEntries() const;
  /// Gaussians in front of the camera with a non-empty tile rectangle in the last forward.
  std::size_t numVisible() const;
  /// GPU time of the stages of the last forward() / backward() [ms] (CUDA events).
  const RasterStageTimes& stageTimes() const;
  const RasterSettings& settings() const;

  /// The stream all work of this rasterizer is queued on (a cudaStream_t).
  void* stream() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho::mapping
