#pragma once
/// \file cuda_trainer.h
/// The device side of GaussianTrainer's iteration: the map's parameters, their Adam moments and
/// the densification statistics live on the GPU; one iteration is render -> masked L1 colour +
/// depth (+ opacity, + SSIM) loss -> backward -> Adam -> statistics, all on the device, with only
/// the loss and the six exposure gradients copied back; densify and prune run there too. Seeding,
/// pose corrections and the opacity reset stay on the host: GaussianTrainer downloads the state,
/// edits it and uploads it again (see gaussian_trainer.h for when).
///
/// The loss is the CPU path's (GaussianTrainer::lossAndGradient) term by term, the optional SSIM
/// term included (ssim_math.h's per-pixel math, SsimLoss's passes). Header free of CUDA types
/// (compiles in every build); without CUDA the constructor throws.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "dypho/mapping/adam_math.h"
#include "dypho/mapping/cuda_rasterizer.h"
#include "dypho/mapping/training_math.h"

namespace dypho::mapping {

/// Parameter blocks of a GaussianMap (position, log_scale, rotation, opacity, sh).
constexpr int kTrainingBlocks = 5;

/// Host arrays of the training state the device mirrors (block p has count * widths[p] floats).
struct TrainingStateView {
  std::size_t count = 0;
  int sh_degree = 0;
  int widths[kTrainingBlocks] = {0, 0, 0, 0, 0};
  float* params[kTrainingBlocks] = {};
  float* first_moment[kTrainingBlocks] = {};
  float* second_moment[kTrainingBlocks] = {};
  float* grad_accum = nullptr;  ///< [count] summed screen-space gradient norms
  int* grad_count = nullptr;    ///< [count] iterations with a gradient
};

/// What densifyAndPrune did, for the host's bookkeeping of ids and anchors (GaussianMap): append
/// a duplicate of each parent in order, then remove the flagged rows.
struct DensifyOutcome {
  std::vector<std::uint32_t> parents;  ///< parent row of each appended Gaussian, in order
  std::vector<std::uint8_t> remove;    ///< [rows before + appended] 1 = removed afterwards
  bool capacity_hit = false;           ///< some children did not fit under the capacity
};

/// Loss of one iteration and dL/d(exposure) (gain k_c, offset b_c; zeros when exposure is off).
struct CudaLossResult {
  double loss = 0.0;
  float exposure_grad[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
};

class CudaTrainer {
 public:
  /// Throws std::runtime_error without CUDA or a usable device.
  explicit CudaTrainer(const RasterSettings& settings = RasterSettings());
  ~CudaTrainer();
  CudaTrainer(const CudaTrainer&) = delete;
  CudaTrainer& operator=(const CudaTrainer&) = delete;

  /// Copies the host state to the device (replaces the device state).
  void upload(const TrainingStateView& host);
  /// Copies the device state into `host` (same count, widths and SH degree as the last upload).
  void download(const TrainingStateView& host);
  /// Gaussians on the device.
  std::size_t size() const;

  /// Stores keyframe `id`'s images on the device: RGB in [0, 1] planar [3, H, W], depth [H, W]
  /// (<= 0 = invalid), static mask [H, W] (non-zero = static). Replaces an earlier one.
  void setTarget(std::int64_t id, int width, int height, const float* rgb, const float* depth_m,
                 const std::uint8_t* static_mask);
  bool hasTarget(std::int64_t id) const;
  void dropTarget(std::int64_t id);
  void clearTargets();

  /// Renders the device map (forward, remembered for backwardAndStep).
  DeviceImages render(const gs::PinholeView<float>& view);
  /// Copies the last render to the host.
  void downloadRender(RenderResult<float>& out);
  /// The loss of the last render against target `id` (the size must match) and its pixel
  /// gradients on the device, GaussianTrainer::lossAndGradient term by term: (1 - lambda) mean
  /// |Mc(exp(k) C_r + b - C)| over static pixels and channels + (lambda mean |M(D_r - D)| +
  /// alpha_weight mean M(1 - A)) over static pixels with depth + ssim_weight (1 - masked SSIM)
  /// (ssim_loss.h; 0 = off). `exposure` (6 values: k_rgb, b_rgb) or null for identity.
  CudaLossResult loss(std::int64_t id, double lambda_depth, double alpha_weight, double ssim_weight,
                      const float* exposure);
  /// Replaces the device pixel gradients by host ones (planar [3, H, W], [H, W], [H, W] of the
  /// last render's size; null = zero).
  void setPixelGrads(const float* color, const float* depth, const float* alpha);
  /// Backward of the last render with the current pixel gradients, one Adam step with `step`,
  /// and the densification statistics (grad_accum += |dL/dmean2d|, grad_count += 1 where > 0).
  /// With `pose_grad` (6 floats), the loss gradient w.r.t. the camera pose is copied there
  /// (GaussianGrads::pose). `isotropy_weight` > 0 adds the isotropy regulariser
  /// (train::addIsotropyGradient, the weight divided by the Gaussians in the map).
  void backwardAndStep(const AdamStepSizes& step, float* pose_grad = nullptr, float isotropy_weight = 0.f);

  /// Densify and prune on the device (GaussianTrainer::densifyAndPrune's rules and order: new
  /// Gaussians appended in parent order up to `capacity` Gaussians in all, split offsets from
  /// `settings.seed`); resets the densification statistics. The device state shrinks or grows.
  DensifyOutcome densifyAndPrune(const DensifySettings& settings, std::size_t capacity);

  CudaRasterizer& rasterizer();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho::mapping
