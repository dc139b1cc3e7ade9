#pragma once
/// \file gaussian_mapper_options.h
/// Settings of the 3D Gaussian Splatting map (`GaussianMapper`) and of all mapping options.

#include <cstddef>
#include <string>

#include "dypho/common/thread_budget.h"
#include "dypho/mapping/cloud_map_options.h"

namespace dypho::mapping {

/// Settings of `GaussianMapper`. Learning rates are Adam step sizes per parameter block.
struct GaussianMapperOptions {
  /// Where training and rendering run: "auto" (CUDA when this build has it and a device is present, else the CPU, said
  /// once), "cpu", or "cuda" (an error when no device is usable). Default "auto".
  std::string device = "auto";
  /// Spherical-harmonic degree of the colours, 0..3 (higher adds view dependence, costs memory and time). Default 0.
  int sh_degree = 0;
  /// Most Gaussians kept; seeding and densification stop adding at the cap, >= 1. Default 300000.
  std::size_t max_gaussians = 300000;
  /// Threads of the rasterizer and optimiser (including the mapping worker), >= 0; 0 = every core of the machine (the
  /// ROS graph: its `cores` thread budget). Default 0.
  int num_threads = 0;
  /// Keyframes are trained and evaluated at 1/train_downsample resolution (1, 2 or 4). Default 2.
  int train_downsample = 2;
  /// Optimisation iterations run after each new keyframe, >= 0. Default 30.
  int iterations_per_keyframe = 30;
  /// Live policy (ROS graph): a keyframe's training stops after this many iterations when the
  /// next job already waits, so the queue never grows, >= 0 (at most iterations_per_keyframe are run). Default 5.
  int live_min_iterations_per_keyframe = 5;
  /// Live policy: with no job waiting the worker keeps training on the stored keyframes (the
  /// idle time of the machine goes into the map). Default true.
  bool live_train_when_idle = true;
  /// Live policy, CPU device: the share of wall time the worker may spend in training iterations,
  /// (0, 1]; after an iteration of t seconds it rests t (1 - d) / d. Training in the idle class
  /// takes no CPU time from the camera-rate threads, but it still slows them through the caches
  /// and memory it shares with them (docs/journal/benchmarks-2026.md); 1 = train whenever there is work. The
  /// offline runner (deterministic mode) and the CUDA device never rest. Default 0.5.
  double live_cpu_training_duty = 0.5;
  /// Nice increment of the mapping worker and its pool threads (thread_budget.h): training takes
  /// the time the camera-rate threads leave, in [0, 19]. Default 10.
  int training_nice = 10;
  /// Linux: the mapping worker and its pool also run in the SCHED_IDLE class, so training gets
  /// only the CPU time no other thread wants and never slows the camera-rate threads (a niced
  /// thread still takes about 10 % of a core it shares with them). False: training_nice alone.
  /// Default true.
  bool training_idle_class = true;
  /// The priority the training threads lower themselves to (training_nice, training_idle_class).
  ThreadPriority trainingPriority() const { return {training_nice, training_idle_class}; }
  /// Iterations of the final refinement run by GaussianMapper::finish() at the end of a sequence,
  /// visiting every stored keyframe equally often, >= 0. Default 300.
  int final_refine_iterations = 300;
  /// Newest keyframes sampled for training (sliding window), >= 1. Default 8.
  int window_size = 8;
  /// Keyframes whose images are kept (training and PSNR); older ones keep only their pose, >= 1. Default 200.
  int max_stored_keyframes = 200;
  /// Weight of the depth term, lambda in (1-lambda)|Mc(Cr-C)|1 + lambda|M(Dr-D)|1, [0, 1]. Default 0.7.
  double lambda_depth = 0.7;
  /// Weight of the opacity term w |M (1 - A)|_1 added to the paper's loss (A: accumulated alpha,
  /// M: static pixels with valid depth); keeps measured surfaces opaque so that D_r is not biased
  /// by partial alpha (0 = the paper's loss only), >= 0. Default 0.1.
  double alpha_weight = 0.1;
  /// Weight of the structural term w (1 - SSIM(Mc; Cr, C)) added to the loss: SSIM of the colour
  /// over static pixels, 11-tap Gaussian window (sigma 1.5 px), see ssim_loss.h (0 = off), >= 0.
  /// Default 0: 0.2 gained 0.05-0.49 dB PSNR offline at every 10th frame (fr1, Bonn, generator)
  /// but none live at 1x, where depth L1 got 0.9 cm worse (docs/journal/benchmarks-2026.md
  /// sections 4 and 11).
  double ssim_weight = 0.0;
  /// Weight of the isotropy regulariser w / N sum_i sum_k |s_ik - mean_k s_ik| over the standard
  /// deviations of the Gaussians visible in an iteration (N: Gaussians in the map), as MonoGS:
  /// keeps needle-like Gaussians that look right only from the keyframes out of the map (0 = off),
  /// >= 0. Default 0.
  double isotropy_weight = 0.0;
  /// Per-keyframe affine exposure (gain exp(k_c), offset b_c per RGB channel) optimised with the
  /// map, as 3DGS SLAM systems do: the loss and the keyframe evaluation compare the keyframe's
  /// image with exp(k) * rendered + b (the first keyframe stays at identity). Default false: views
  /// of the map are rendered without an exposure of their own, and a map trained on the plain
  /// colours fits them better (at every 10th frame +1.24 dB on fr1/rpy, Bonn unchanged offline and
  /// live, -0.11 dB on the generator; docs/journal/benchmarks-2026.md section 12).
  bool exposure_compensation = false;
  /// Adam step size of the exposure parameters, >= 0. Default 0.01.
  double lr_exposure = 0.01;
  /// With exposure_compensation, the end of a run (GaussianMapper::finish) moves the map's colours
  /// into the mean exposure of its keyframes, and each keyframe's exposure becomes relative to it
  /// (the keyframes' renders do not change). Otherwise the map keeps the first keyframe's
  /// exposure, which a camera's auto-exposure may still be settling in. Default false.
  bool exposure_mean_gauge = false;
  /// Joint refinement of the keyframe poses with the Gaussians (as MonoGS does): each training
  /// iteration also takes an Adam step on the trained keyframe's pose from the rasterizer's pose
  /// gradient. The first keyframe stays fixed (it holds the gauge). A tracking correction moves
  /// the refined pose with the tracker's, keeping the refinement's offset; the refined poses go
  /// back to tracking at the end of a run (GaussianMapper::keyframePoses). Default false.
  bool pose_refinement = false;
  /// Adam step size of the keyframe translation (pose_refinement) [m], >= 0. Default 2e-4.
  double lr_pose_translation_m = 2e-4;
  /// Adam step size of the keyframe rotation (pose_refinement) [rad], >= 0. Default 5e-4.
  double lr_pose_rotation_rad = 5e-4;
  /// A refinement step that would take a keyframe further than this from the tracker's pose is
  /// not applied [m], > 0. Default 0.05.
  double pose_refinement_max_translation_m = 0.05;
  /// The same bound on the rotation [rad], > 0. Default 0.035 (2 degrees).
  double pose_refinement_max_rotation_rad = 0.035;
  /// Share of training iterations that sample any stored keyframe instead of the window
  /// (keeps older parts of the map from drifting), [0, 1]. Default 0.2.
  double global_sample_ratio = 0.2;
  /// Training picks the keyframe trained least so far (ties: the newest) within the window, and
  /// among all stored keyframes for the global share, instead of a uniform random one: keyframes
  /// seeded while mapping was behind get their share first. Default false.
  bool least_trained_first = false;
  /// Depths outside [valid_min_depth_m, valid_max_depth_m] are invalid for Gaussian seeding and the loss [m]. Default
  /// 0.1.
  double valid_min_depth_m = 0.1;
  /// Far depth limit of the Gaussian map [m], > valid_min_depth_m. Default 6.0.
  double valid_max_depth_m = 6.0;
  /// Opacity of new Gaussians, (0, 1). Default 0.5 (the paper).
  double initial_opacity = 0.5;
  /// Extra Gaussians sampled around each keypoint (the paper's densification at features), >= 0. Default 4.
  int feature_samples = 4;
  /// Radius of those samples around the keypoint [px] (at full resolution), > 0. Default 6.
  double feature_sample_radius_px = 6.0;
  /// Grid step of the coverage of unexplained static pixels [px] (at full resolution), >= 1. Default 8.
  int coverage_stride_px = 8;
  /// A pixel is unexplained when the rendered alpha is below this, [0, 1]. Default 0.9 (0.6 left see-through gaps where
  /// people later pass: docs/journal/benchmarks-2026.md section 4).
  double coverage_alpha_threshold = 0.9;
  /// ... or when |rendered depth / alpha - depth| exceeds this fraction of the depth, > 0. Default 0.05.
  double coverage_depth_error_ratio = 0.05;
  /// Also cover static pixels without valid depth (black screens, out of range) where nothing is
  /// rendered, at the farthest depth of the nearest measured static nodes of the coverage grid
  /// (the colour term then trains them; they have no depth term). Default true.
  bool coverage_fill_invalid_depth = true;
  /// Adam step size of positions [m]. Default 0.0005.
  double lr_position = 0.0005;
  /// Adam step size of log-scales. Default 0.005.
  double lr_log_scale = 0.005;
  /// Adam step size of quaternions. Default 0.001.
  double lr_rotation = 0.001;
  /// Adam step size of opacity logits. Default 0.05.
  double lr_opacity = 0.05;
  /// Adam step size of the SH DC coefficients. Default 0.01 (3DGS's 0.0025 is for 30k iterations;
  /// a keyframe here gets a few tens).
  double lr_sh_dc = 0.01;
  /// Adam step size of the higher SH coefficients. Default 0.000125.
  double lr_sh_rest = 0.000125;
  /// Densify and prune every this many iterations (0 = never), >= 0. Default 100.
  int densify_interval = 100;
  /// Mean screen-space position gradient above which a Gaussian is cloned or split [1/px], > 0. Default 0.0002.
  double densify_grad_threshold = 0.0002;
  /// Gaussians larger than this (largest std dev) are split, smaller ones cloned [m], > 0. Default 0.02.
  double densify_scale_threshold_m = 0.02;
  /// Gaussians with opacity below this are pruned, [0, 1). Default 0.005.
  double prune_min_opacity = 0.005;
  /// Gaussians with a std dev above this are pruned [m], > 0. Default 0.3.
  double prune_max_scale_m = 0.3;
  /// Reset opacities to at most 0.01 every this many iterations (0 = never), >= 0. Default 0:
  /// with a sliding window, a reset would erase the parts of the map outside the window.
  int opacity_reset_interval = 0;
  /// Seed of the keyframe sampler and of the feature samples. Default 1.
  int random_seed = 1;

  /// num_threads, with 0 resolved to every core of this machine.
  int resolvedNumThreads() const;
  /// Throws std::invalid_argument naming the first field out of range and its range.
  void validate() const;
  /// One line "key=value ..." with every field.
  std::string toString() const;
};

/// Everything in config/mapping.yaml: the point-cloud map and the Gaussian map.
struct MappingOptions {
  CloudMapOptions cloud;           ///< coloured point cloud (map.pcd)
  GaussianMapperOptions gaussian;  ///< 3D Gaussian map (map.ply, rendering)

  void validate() const {
    cloud.validate();
    gaussian.validate();
  }
  std::string toString() const { return cloud.toString() + " " + gaussian.toString(); }
};

}  // namespace dypho::mapping
