#pragma once
/// \file raster_types.h
/// The data the rasterizers exchange, shared by the CPU path (rasterizer.h) and the CUDA path
/// (cuda_rasterizer.h): settings, parameter views, images, gradients, the projected-Gaussian
/// record and the tile lists. No OpenCV, no Eigen, no CUDA include: nvcc compiles this header.

#include <cstdint>
#include <vector>

#include "dypho/mapping/gaussian_math.h"

namespace dypho::mapping {

/// Instruction set of the CPU tile kernels (the per-tile compositing loops, forward and backward).
/// Both sets are compiled into every x86-64 build; the CPU is asked at run time.
enum class RasterIsa {
  kAuto,     ///< AVX2+FMA when this CPU has them, else generic
  kGeneric,  ///< the build's baseline instruction set (SSE2 on x86-64): runs on every CPU
  kAvx2,     ///< AVX2+FMA; constructing a Rasterizer with it on a CPU without them throws
};

/// Numerical settings of the rasterizer (defaults = 3DGS).
struct RasterSettings {
  /// Footprint radius in standard deviations of the largest screen axis, > 0. Default 3.
  double radius_sigma = 3.0;
  /// Per-Gaussian alpha below which a pixel skips the Gaussian, >= 0. Default 1/255.
  double min_alpha = 1.0 / 255.0;
  /// Transmittance below which a pixel stops compositing, >= 0. Default 1e-4.
  double min_transmittance = 1e-4;
  /// Tile kernels; default kAuto. The two sets agree to rounding (FMA contracts some products).
  RasterIsa isa = RasterIsa::kAuto;
};

namespace raster {

/// Tile-list entries ahead of the current one whose Gaussian is prefetched.
constexpr std::uint32_t kPrefetchAhead = 6;

/// One projected Gaussian as the tile kernels read it; cache-line aligned (64 bytes for float) so
/// that a tile's lookup of it touches a single line.
template <typename T>
struct alignas(64) PackedGaussian {
  T mean_u, mean_v, conic_a, conic_b, conic_c, opacity, color[3], depth;
  T half_u, half_v;                        ///< footprint box half sizes [px] (gs::Projected)
  int tile_x0, tile_y0, tile_x1, tile_y1;  ///< tile rectangle [x0, x1) x [y0, y1); empty = culled
};

}  // namespace raster

/// Read-only view of Gaussian parameters in the SoA layout of GaussianMap (rows of 3, 3, 4, 1, 3K).
template <typename T>
struct GaussianParamsView {
  const T* position = nullptr;       ///< [N, 3] world [m]
  const T* log_scale = nullptr;      ///< [N, 3] log std dev [log m]
  const T* rotation = nullptr;       ///< [N, 4] quaternion w x y z
  const T* opacity_logit = nullptr;  ///< [N]
  const T* sh = nullptr;             ///< [N, K, 3] coefficient-major RGB
  int count = 0;                     ///< N
  int sh_degree = 0;                 ///< 0..3 (K = (degree+1)^2)
};

/// Rendered images, planar, row-major, width x height.
template <typename T>
struct RenderResult {
  int width = 0, height = 0;
  std::vector<T> color;  ///< [3, H, W] RGB in [0, ~1], black background
  std::vector<T> depth;  ///< [H, W] D = sum d_i alpha_i T_i [m] (not normalised by alpha)
  std::vector<T> alpha;  ///< [H, W] accumulated alpha = 1 - final transmittance
};

/// Per-pixel loss gradients fed to the backward pass; null pointers mean zero.
template <typename T>
struct PixelGrads {
  const T* color = nullptr;  ///< [3, H, W] dL/dcolor
  const T* depth = nullptr;  ///< [H, W] dL/ddepth
  const T* alpha = nullptr;  ///< [H, W] dL/dalpha
};

/// Gradients of the loss w.r.t. the Gaussian parameters (same layout as GaussianParamsView).
template <typename T>
struct GaussianGrads {
  std::vector<T> position, log_scale, rotation, opacity_logit, sh;
  /// [N] |dL/d(mean_u, mean_v)| [1/px], the screen-space gradient used for densification.
  std::vector<T> mean2d_norm;
  /// d/d(rho, phi) for a left perturbation of T_camera_world (translation rho [m], rotation phi
  /// [rad]): T_cw <- exp([rho, phi]) * T_cw.
  T pose[6] = {0, 0, 0, 0, 0, 0};
};

/// Wall time of the stages of the last forward() and backward() [ms] (for benchmarks).
struct RasterStageTimes {
  double project_ms = 0;     ///< forward: cull + projection of every Gaussian
  double bin_ms = 0;         ///< forward: depth sort and tile lists
  double composite_ms = 0;   ///< forward: per-tile compositing
  double tiles_back_ms = 0;  ///< backward: per-tile back-to-front pass
  double chain_ms = 0;       ///< backward: per-Gaussian chain rule
};

namespace raster {

/// What the tile kernels read of one forward pass: the tile lists and the projected Gaussians.
template <typename T>
struct TileLists {
  int tiles_x = 0;                               ///< tiles per row
  int width = 0, height = 0;                     ///< image size [px]
  const std::uint32_t* ranges = nullptr;         ///< [tiles + 1] offsets into `entries`
  const std::uint32_t* entries = nullptr;        ///< per (tile, depth-ordered) slot: index into `sorted`
  const PackedGaussian<T>* sorted = nullptr;     ///< visible Gaussians in depth order
  T min_alpha = T(0), min_transmittance = T(0);  ///< RasterSettings
};

/// Images a forward tile kernel writes (planar, row-major).
template <typename T>
struct ForwardImages {
  T* color = nullptr;                   ///< [3, H, W]
  T* depth = nullptr;                   ///< [H, W]
  T* alpha = nullptr;                   ///< [H, W]
  T* final_T = nullptr;                 ///< [H, W] transmittance after the last Gaussian
  std::uint32_t* last_entry = nullptr;  ///< [H, W] one past the last contributing entry
};

/// What a backward tile kernel reads besides the lists: the forward's record and the loss.
template <typename T>
struct BackwardInputs {
  const T* final_T = nullptr;
  const std::uint32_t* last_entry = nullptr;
  PixelGrads<T> grads;
};

}  // namespace raster

}  // namespace dypho::mapping
