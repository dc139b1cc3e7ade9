#pragma once
/// \file rasterizer.h
/// CPU tile rasterizer of 3D Gaussians: forward (colour, depth D = sum d_i alpha_i T_i, accumulated
/// alpha) and backward (gradients of every Gaussian parameter and of the camera pose). Templated on
/// the scalar: float is the production path, double is used by the gradient checks.
///
/// Stages (each over preallocated buffers that only grow): project every Gaussian (parallel over
/// Gaussians; gs::mayReachImage drops most off-screen ones before gs::projectGaussian) -> depth
/// radix sort + binning into 16x16 tiles (lists come out sorted front to back) -> per tile,
/// Gaussian-outer / pixel-inner compositing over the Gaussian's footprint box inside the tile
/// (radius_sigma box cut to where alpha can reach min_alpha), rows in 8-pixel blocks, with
/// per-pixel early stop (parallel over tiles). The backward pass walks each tile's list back to
/// front and recovers the transmittance by division, as 3DGS does; its per-Gaussian chain rule
/// runs in parameter order.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/mapping/raster_types.h"
#include "dypho/mapping/thread_pool.h"

namespace dypho {
struct CameraIntrinsics;
}  // namespace dypho

namespace dypho::mapping {

/// "auto", "generic" or "avx2".
const char* rasterIsaName(RasterIsa isa);
/// True when this build has the AVX2+FMA kernels and this CPU (and OS) can run them.
bool rasterAvx2Available();

namespace raster {

/// One set of tile kernels (generic or AVX2; see RasterIsa). `forward` renders one tile;
/// `backward` adds one tile's screen-space gradients into `acc` ([visible], indexed like `sorted`).
template <typename T>
struct TileKernels {
  void (*forward)(const TileLists<T>& lists, int tile, const ForwardImages<T>& out) = nullptr;
  void (*backward)(const TileLists<T>& lists, int tile, const BackwardInputs<T>& in, gs::ScreenGrad<T>* acc) = nullptr;
};

}  // namespace raster

/// Builds the projection view from a pose and undistorted pinhole intrinsics (distortion ignored).
template <typename T>
gs::PinholeView<T> makePinholeView(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera);

/// The rasterizer. Holds its scratch buffers; reuse one object per thread of use. Not thread-safe.
template <typename T>
class Rasterizer {
 public:
  /// `pool` (not owned, may be shared with other users that do not run concurrently) runs the
  /// parallel stages.
  Rasterizer(ThreadPool* pool, const RasterSettings& settings = RasterSettings());

  /// Renders `params` seen from `view` into `out` (resized; allocation only when it grows).
  /// Remembers `params` and `view` for the next backward(); the arrays must stay unchanged until then.
  void forward(const GaussianParamsView<T>& params, const gs::PinholeView<T>& view, RenderResult<T>& out);

  /// Gradients of a loss whose per-pixel gradients are `grads`, for the last forward().
  void backward(const PixelGrads<T>& grads, GaussianGrads<T>& out);

  /// (Gaussian, tile) pairs of the last forward.
  std::size_t numTileEntries() const { return entries_.size(); }
  /// Gaussians in front of the camera with a non-empty footprint in the last forward.
  std::size_t numVisible() const { return num_visible_; }
  const RasterSettings& settings() const { return settings_; }
  /// Tile kernels in use: kGeneric or kAvx2 (settings().isa resolved against this CPU).
  RasterIsa isa() const { return isa_; }
  /// Stage times of the last forward() / backward().
  const RasterStageTimes& stageTimes() const { return times_; }

 private:
  using Packed = raster::PackedGaussian<T>;
  static constexpr std::uint32_t kPrefetchAhead = raster::kPrefetchAhead;
  void preprocess();
  void binTiles();
  raster::TileLists<T> tileLists() const;

  ThreadPool* pool_;
  RasterSettings settings_;
  RasterIsa isa_ = RasterIsa::kGeneric;  ///< kernels in use (never kAuto)
  raster::TileKernels<T> kernels_{};
  RasterStageTimes times_;
  GaussianParamsView<T> params_;
  gs::PinholeView<T> view_{};
  int tiles_x_ = 0, tiles_y_ = 0;
  std::size_t num_visible_ = 0;
  std::vector<Packed> packed_;         ///< [N] per Gaussian (valid where visible_)
  std::vector<std::uint8_t> visible_;  ///< [N] 1 = projected with a non-empty tile rectangle
  std::vector<Packed> sorted_;         ///< [visible] visible Gaussians in depth order (tile lists index it)
  std::vector<std::uint32_t> keys_, order_, sort_tmp_keys_, sort_tmp_order_;
  static constexpr std::uint32_t kNotVisible = 0xffffffffu;
  std::vector<std::uint32_t> rank_;         ///< [N] index into sorted_, or kNotVisible
  std::vector<std::uint32_t> tile_ranges_;  ///< [tiles + 1] offsets into entries_
  std::vector<std::uint32_t> tile_fill_;
  std::vector<std::uint32_t> entries_;                        ///< index into sorted_ per (tile, depth-sorted) slot
  std::vector<T> final_T_;                                    ///< [H, W]
  std::vector<std::uint32_t> last_entry_;                     ///< [H, W] one past the last contributing entry
  std::vector<std::vector<gs::ScreenGrad<T>>> thread_grads_;  ///< [threads][visible]
  std::vector<std::vector<T>> thread_pose_;
};

extern template class Rasterizer<float>;
extern template class Rasterizer<double>;

}  // namespace dypho::mapping
