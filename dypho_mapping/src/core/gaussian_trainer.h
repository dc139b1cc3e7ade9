#pragma once
/// GaussianTrainer: the map, its optimiser and the training keyframes; seeds keyframes,
/// runs optimisation iterations, re-anchors corrected keyframes. Not thread-safe: GaussianMapper
/// holds its lock around every call.

#include <cstdint>
#include <memory>
#include <random>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/mapping/adam.h"
#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/cuda_trainer.h"
#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/gaussian_mapper.h"
#include "dypho/mapping/keyframe_evaluation.h"
#include "dypho/mapping/rasterizer.h"
#include "dypho/mapping/ray_cache.h"
#include "dypho/mapping/ssim_loss.h"

namespace dypho::mapping {

/// A keyframe as the optimiser sees it: undistorted, at training resolution.
struct TrainingKeyframe {
  std::int64_t id = -1;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  CameraIntrinsics camera;  ///< pinhole at training resolution
  cv::Mat bgr;              ///< CV_8UC3 (empty once the images were dropped)
  cv::Mat depth_m;          ///< CV_32FC1, 0 = invalid (range-checked)
  cv::Mat static_mask;      ///< CV_8UC1, 255 = static (colour term), 0 = dynamic
  /// Affine exposure of this keyframe's image (exposure_compensation): channel c (RGB) of the
  /// image is modelled as exp(exposure[c]) * rendered + exposure[3 + c]. Identity = zeros.
  float exposure[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  float exposure_m[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};  ///< Adam first moments
  float exposure_v[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};  ///< Adam second moments
  int exposure_steps = 0;
  std::int64_t trained_iterations = 0;  ///< optimisation iterations run on this keyframe
  /// The pose tracking gave (with its corrections); T_world_camera is this pose refined with the
  /// map (pose_refinement), or the same pose.
  Eigen::Isometry3d T_world_camera_tracked = Eigen::Isometry3d::Identity();
  float pose_m[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};  ///< Adam first moments of the pose step
  float pose_v[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};  ///< Adam second moments of the pose step
  int pose_steps = 0;
  std::size_t pose_steps_refused = 0;  ///< steps beyond the pose_refinement_max_* bounds
  bool hasImages() const { return !bgr.empty(); }
};

/// Pixels of a keyframe's loss: static ones (colour term) and those of them with a depth.
struct TrainingTargetCounts {
  std::size_t static_pixels = 0;
  std::size_t depth_pixels = 0;
};

/// Undistortion maps of one camera onto the pinhole with the same fx fy cx cy.
struct Undistorter {
  CameraIntrinsics camera;
  cv::Mat map1, map2;
};

/// With `device` kCuda the optimisation iterations run on the GPU (CudaTrainer) and the training
/// state (map parameters, Adam moments, densification statistics) lives there between them; the
/// host copy (`map`, `adam`, `grad_accum`, `grad_count`) is brought up to date by syncToHost()
/// before any host read or edit, and every host edit ends with hostChanged() so that the next
/// iteration uploads it. hostMap() does the first for readers outside the trainer.
struct GaussianTrainer {
  GaussianTrainer(const GaussianMapperOptions& o, ComputeDevice device);
  /// Re-anchors the Gaussians of each listed keyframe to its new pose (unknown ids and non-rigid
  /// poses are ignored); returns how many keyframes moved.
  std::size_t correctKeyframePoses(const KeyframePoseCorrections& corrections);
  /// Removes every Gaussian and keyframe.
  void clear();

  /// The map, up to date (downloads the device state first when it is newer).
  GaussianMap& hostMap();
  /// Brings the host training state up to date with the device (no-op on the CPU path).
  void syncToHost();
  /// Marks the host training state as edited: the next GPU iteration uploads it.
  void hostChanged();
  /// After a CUDA failure: training goes on on the CPU from the host copy as last synced
  /// (its structure is always current), and `device_fallback` says why.
  void leaveGpu(const std::string& reason);

  GaussianParamsView<float> params() const;
  /// Seeds a validated keyframe (see GaussianMapper::addKeyframe).
  AddKeyframeResult integrate(const Keyframe& keyframe);
  /// One optimisation iteration on a keyframe of the window (or, 1 time in global_sample_ratio,
  /// of all stored ones); with `all_keyframes`, on the next keyframe of a shuffled pass over every
  /// stored keyframe (final refinement). Returns the loss (or -1 when there is nothing to train on).
  double iterate(bool all_keyframes = false);
  /// One Adam step on `kf`'s exposure from exposure_grad.
  void stepExposure(TrainingKeyframe& kf);
  /// One Adam step on `kf`'s pose from the loss gradient `grad` (d/d(rho, phi) of a left
  /// perturbation of T_camera_world, GaussianGrads::pose); a step beyond the pose_refinement_max_*
  /// bounds from the tracked pose is not applied.
  void stepPose(TrainingKeyframe& kf, const float grad[6]);
  /// exposure_mean_gauge: the map's colours c -> exp(mean k) c + mean b (over the keyframes'
  /// exposures), each keyframe's exposure re-expressed so that its render does not change.
  void centreExposureGauge();
  /// Adds the isotropy regulariser's gradient (options.isotropy_weight, train::addIsotropyGradient)
  /// to grads.log_scale of the Gaussians visible in the last backward pass.
  void addIsotropyGradients();
  void densifyAndPrune();
  /// densifyAndPrune() on the device (CudaTrainer), the host copy following in structure.
  void densifyAndPruneOnDevice();
  void resetOpacity();
  const Undistorter& undistorter(const CameraIntrinsics& camera);
  /// Renders the map into `out` with `raster` (pinhole camera, distortion ignored).
  void renderPinhole(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& pinhole,
                     Rasterizer<float>& raster, RenderResult<float>& out);
  /// Per-pixel loss and its gradient (writes pix_gc, pix_gd, pix_ga and exposure_grad; the
  /// math of training_math.h); returns the loss.
  double lossAndGradient(const TrainingKeyframe& kf, const RenderResult<float>& r);
  /// The keyframe's images in the loss's layout (target_rgb: planar RGB in [0, 1], target_depth,
  /// target_mask) and its pixel counts.
  TrainingTargetCounts fillTarget(const TrainingKeyframe& kf);
  /// The densify settings from the options, with the next split seed from `rng`.
  DensifySettings nextDensifySettings();

  /// One iteration on the GPU (iterate() with a CUDA device); returns the loss.
  double iterateCuda(TrainingKeyframe& kf, bool fixed_exposure);
  /// Host arrays of the training state for CudaTrainer::upload/download (sizes made consistent).
  TrainingStateView stateView();

  GaussianMapperOptions options;
  ComputeDevice device = ComputeDevice::kCpu;
  std::unique_ptr<CudaTrainer> cuda;  ///< set when device is kCuda
  std::string device_fallback;        ///< why training left the GPU (empty: it did not)
  /// Where the training state is current: both, the host only (edited), the device only (trained).
  enum class Current { kBoth, kHost, kDevice } current = Current::kBoth;
  std::vector<float> target_rgb;          ///< scratch: a keyframe's planar RGB (loss, CudaTrainer::setTarget)
  std::vector<float> target_depth;        ///< scratch: its depth (continuous rows)
  std::vector<std::uint8_t> target_mask;  ///< scratch: its static mask
  GaussianMap map;
  ThreadPool pool;
  Rasterizer<float> raster;         ///< training (forward + backward)
  Rasterizer<float> render_raster;  ///< renders for seeding and evaluation
  Adam adam;
  std::mt19937 rng;
  std::vector<TrainingKeyframe> keyframes;  ///< insertion order
  std::vector<Undistorter> undistorters;
  UndistortedRayCache rays;  ///< distorted-pixel rays for mapping renders back
  std::int64_t iterations = 0;
  double last_loss = 0.0;
  std::size_t skipped = 0, capacity_hits = 0;
  std::vector<float> grad_accum;  ///< [N] summed screen-space gradient norms since last densify
  std::vector<int> grad_count;    ///< [N] iterations in which the Gaussian was visible
  RenderResult<float> train_out, seed_out, view_out;
  GaussianGrads<float> grads;
  std::vector<float> pix_gc, pix_gd, pix_ga;
  std::vector<std::size_t> sample_all;                      ///< scratch: indices of keyframes with images
  std::vector<std::size_t> refine_order;                    ///< keyframes left in the current refinement pass
  SsimLoss<float> ssim;                                     ///< structural term of the loss (options.ssim_weight > 0)
  std::vector<float> shown;                                 ///< [3, H, W] the colour the loss compares (SSIM term)
  float exposure_grad[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};  ///< dL/d exposure of the last loss
  float pose_grad[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};      ///< dL/d pose of the last iteration (CUDA path)
};

/// PSNR on static pixels and depth L1 of `trainer`'s map at its stored keyframes; with
/// `side_by_side_dir`, writes kf_<id>.png there (GaussianMapper::evaluateKeyframes). With
/// `budget_s`, no keyframe is started after that wall time; the keyframes are taken in an order
/// spread over the run, so those evaluated sample all of it.
KeyframeEvaluation evaluateKeyframes(GaussianTrainer& trainer, const std::string& side_by_side_dir,
                                     std::optional<double> budget_s = std::nullopt);

/// True when the pose is finite and its rotation orthonormal (1e-3).
bool isRigidPose(const Eigen::Isometry3d& T);

/// Throws nothing; returns an empty string when the keyframe is usable, else why not.
std::string checkKeyframe(const Keyframe& keyframe);

}  // namespace dypho::mapping
