#pragma once
/// \file map_renderer.h
/// Renders a Gaussian map (usually a snapshot, GaussianMapper::latestSnapshot) at a pose through
/// a camera: colour, depth and alpha. It has its own rasterizer and thread pool, so it renders
/// outside the mapper's lock and never holds up training. This is the paper's R_d(G, T) when only
/// the depth is taken.
///
/// Cameras with plumb_bob distortion: the map is rendered in the pinhole with the same fx fy cx cy
/// and mapped back into the distorted image, so the output lines up with the input images.
/// Not thread-safe: one renderer per thread.

#include <memory>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/camera.h"
#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/cuda_rasterizer.h"
#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/rasterizer.h"
#include "dypho/mapping/ray_cache.h"
#include "dypho/mapping/thread_pool.h"

namespace dypho::mapping {

/// A rendered view.
struct RenderedView {
  cv::Mat bgr;  ///< CV_8UC3 BGR
  /// CV_32FC1 [m]: D_r / alpha (D_r = sum d_i alpha_i T_i) where alpha >= 0.5, else 0 (no
  /// measurement). The alpha term of the loss keeps alpha ~1 on measured surfaces, where this is D_r.
  cv::Mat depth_m;
  cv::Mat alpha;  ///< CV_32FC1 accumulated alpha in [0, 1]
};

class MapRenderer {
 public:
  /// `num_threads` >= 1 (the caller included).
  /// With `device` kCuda the renders run on the GPU (CudaRasterizer), else on the CPU with
  /// `num_threads` threads.
  explicit MapRenderer(int num_threads = 1, ComputeDevice device = ComputeDevice::kCpu);

  /// Colour, depth and alpha of `map` seen from `T_world_camera` through `camera` (its size and
  /// distortion). Throws std::invalid_argument for invalid intrinsics or a non-finite pose.
  RenderedView render(const GaussianMap& map, const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera);
  /// Depth only (CV_32FC1 [m], 0 = nothing rendered): R_d(G, T).
  cv::Mat renderDepth(const GaussianMap& map, const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera);
  /// The same for an immutable snapshot (MapSnapshot::map): on the GPU a snapshot is uploaded
  /// once and kept on the device while it stays the latest one rendered (the live map, above,
  /// is uploaded per render).
  RenderedView render(const std::shared_ptr<const GaussianMap>& snapshot, const Eigen::Isometry3d& T_world_camera,
                      const CameraIntrinsics& camera);
  cv::Mat renderDepth(const std::shared_ptr<const GaussianMap>& snapshot, const Eigen::Isometry3d& T_world_camera,
                      const CameraIntrinsics& camera);
  /// Why renders left the GPU after a CUDA failure (they continue on the CPU); empty if they did not.
  const std::string& deviceFallback() const { return device_fallback_; }

 private:
  ThreadPool pool_;
  Rasterizer<float> raster_;
  std::unique_ptr<CudaRasterizer> cuda_;  ///< set for ComputeDevice::kCuda
  /// Renders `out_` (the GPU: `snapshot` when it is the uploaded one, else uploads `map`).
  RenderedView renderImpl(const GaussianMap& map, const std::shared_ptr<const GaussianMap>* snapshot,
                          const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera);

  RenderResult<float> out_;
  UndistortedRayCache rays_;
  std::shared_ptr<const GaussianMap> on_device_;  ///< the snapshot whose parameters cuda_ holds
  std::string device_fallback_;                   ///< why renders left the GPU (empty: they did not)
};

/// The parameter view the rasterizer reads (no copy).
GaussianParamsView<float> paramsView(const GaussianMap& map);

}  // namespace dypho::mapping
