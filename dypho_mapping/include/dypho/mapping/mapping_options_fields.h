#pragma once
/// \file mapping_options_fields.h
/// The lists of mapping option keys, written once: parameter readers (ROS private params, YAML
/// files) and printers visit the fields through `visitOptions`. Keep them in the order of the structs.

#include "dypho/mapping/cloud_map_options.h"
#include "dypho/mapping/gaussian_mapper_options.h"

namespace dypho::mapping {

/// Calls `visitor(key, field, doc)` for every field of `options`.
template <typename Visitor>
void visitOptions(CloudMapOptions& options, Visitor&& visitor) {
  visitor("pixel_stride", options.pixel_stride,
          "Every pixel_stride-th pixel along rows and columns is unprojected [px], >= 1. Default 4.");
  visitor("min_depth_m", options.min_depth_m, "Depths below this are ignored [m], >= 0. Default 0.1.");
  visitor("max_depth_m", options.max_depth_m, "Depths above this are ignored [m], > min_depth_m. Default 4.0.");
  visitor("voxel_size_m", options.voxel_size_m,
          "Leaf size of the voxel-grid filter applied by `buildCloud()` [m], >= 0 (0 = no filter). Default 0.02.");
  visitor("max_points", options.max_points,
          "Hard cap on the points stored over all keyframes (before voxel filtering), >= 1. When a new keyframe would "
          "exceed it, that keyframe is skipped (oldest data kept). Default 2 000 000.");
}

/// The map's size, device, threads and training schedule (GaussianMapperOptions).
template <typename Visitor>
void visitScheduleOptions(GaussianMapperOptions& options, Visitor&& visitor) {
  visitor("device", options.device,
          "Where training and rendering run: \"auto\" (CUDA when this build has it and a device is present, else the "
          "CPU, said once), \"cpu\", or \"cuda\" (an error when no device is usable). Default \"auto\".");
  visitor("sh_degree", options.sh_degree,
          "Spherical-harmonic degree of the colours, 0..3 (higher adds view dependence, costs memory and time). "
          "Default 0.");
  visitor("max_gaussians", options.max_gaussians,
          "Most Gaussians kept; seeding and densification stop adding at the cap, >= 1. Default 300000.");
  visitor("num_threads", options.num_threads,
          "Threads of the rasterizer and optimiser (including the mapping worker), >= 0; 0 = every core of the machine "
          "(the ROS graph: its `cores` thread budget). Default 0.");
  visitor("train_downsample", options.train_downsample,
          "Keyframes are trained and evaluated at 1/train_downsample resolution (1, 2 or 4). Default 2.");
  visitor("iterations_per_keyframe", options.iterations_per_keyframe,
          "Optimisation iterations run after each new keyframe, >= 0. Default 30.");
  visitor("live_min_iterations_per_keyframe", options.live_min_iterations_per_keyframe,
          "Live policy (ROS graph): a keyframe's training stops after this many iterations when the next job already "
          "waits, so the queue never grows, >= 0 (at most iterations_per_keyframe are run). Default 5.");
  visitor("live_train_when_idle", options.live_train_when_idle,
          "Live policy: with no job waiting the worker keeps training on the stored keyframes (the idle time of the "
          "machine goes into the map). Default true.");
  visitor("live_cpu_training_duty", options.live_cpu_training_duty,
          "Live policy, CPU device: the share of wall time the worker may spend in training iterations, (0, 1]; after "
          "an iteration of t seconds it rests t (1 - d) / d. Training in the idle class takes no CPU time from the "
          "camera-rate threads, but it still slows them through the caches and memory it shares with them; 1 = train "
          "whenever there is work. The offline runner and the CUDA device never rest. Default 0.5.");
  visitor("training_nice", options.training_nice,
          "Nice increment of the mapping worker and its pool threads: training takes the time the camera-rate threads "
          "leave, in [0, 19]. Default 10.");
  visitor("training_idle_class", options.training_idle_class,
          "Linux: the mapping worker and its pool also run in the SCHED_IDLE class, so training gets only the CPU time "
          "no other thread wants and never slows the camera-rate threads (a niced thread still takes about 10 % of a "
          "core it shares with them). False: training_nice alone. Default true.");
  visitor("final_refine_iterations", options.final_refine_iterations,
          "Iterations of the final refinement run by GaussianMapper::finish() at the end of a sequence, visiting every "
          "stored keyframe equally often, >= 0. Default 300.");
  visitor("window_size", options.window_size,
          "Newest keyframes sampled for training (sliding window), >= 1. Default 8.");
  visitor("max_stored_keyframes", options.max_stored_keyframes,
          "Keyframes whose images are kept (training and PSNR); older ones keep only their pose, >= 1. Default 200.");
}

/// The loss and the seeding of new Gaussians (GaussianMapperOptions).
template <typename Visitor>
void visitLossAndSeedingOptions(GaussianMapperOptions& options, Visitor&& visitor) {
  visitor("lambda_depth", options.lambda_depth,
          "Weight of the depth term, lambda in (1-lambda)|Mc(Cr-C)|1 + lambda|M(Dr-D)|1, [0, 1]. Default 0.7.");
  visitor("alpha_weight", options.alpha_weight,
          "Weight of the opacity term w |M (1 - A)|_1 added to the paper's loss (A: accumulated alpha, M: static "
          "pixels with valid depth); keeps measured surfaces opaque so that D_r is not biased by partial alpha (0 = "
          "the paper's loss only), >= 0. Default 0.1.");
  visitor(
      "ssim_weight", options.ssim_weight,
      "Weight of the structural term w (1 - SSIM(Mc; Cr, C)) added to the loss: SSIM of the colour over static "
      "pixels, 11-tap Gaussian window (sigma 1.5 px), see ssim_loss.h (0 = off), >= 0. Default 0: 0.2 gained "
      "0.05-0.49 dB PSNR offline at every 10th frame (fr1, Bonn, generator) but none live at 1x, where depth L1 got "
      "0.9 cm worse (docs/journal/benchmarks-2026.md sections 4 and 11).");
  visitor("isotropy_weight", options.isotropy_weight,
          "Weight of the isotropy regulariser w / N sum_i sum_k |s_ik - mean_k s_ik| over the standard deviations of "
          "the Gaussians visible in an iteration (N: Gaussians in the map), as MonoGS: keeps needle-like Gaussians "
          "that look right only from the keyframes out of the map (0 = off), >= 0. Default 0.");
  visitor("exposure_compensation", options.exposure_compensation,
          "Per-keyframe affine exposure (gain exp(k_c), offset b_c per RGB channel) optimised with the map, as 3DGS "
          "SLAM systems do: the loss and the keyframe evaluation compare the keyframe's image with exp(k) * "
          "rendered + b (the first keyframe stays at identity). Default false: views of the map are rendered "
          "without an exposure of their own, and a map trained on the plain colours fits them better (at every 10th "
          "frame +1.24 dB on fr1/rpy, Bonn unchanged offline and live, -0.11 dB on the generator; "
          "docs/journal/benchmarks-2026.md section 12).");
  visitor("lr_exposure", options.lr_exposure, "Adam step size of the exposure parameters, >= 0. Default 0.01.");
  visitor("exposure_mean_gauge", options.exposure_mean_gauge,
          "With exposure_compensation, the end of a run (GaussianMapper::finish) moves the map's colours into the "
          "mean exposure of its keyframes, and each keyframe's exposure becomes relative to it (the keyframes' "
          "renders do not change). Otherwise the map keeps the first keyframe's exposure, which a camera's "
          "auto-exposure may still be settling in. Default false.");
  visitor("pose_refinement", options.pose_refinement,
          "Joint refinement of the keyframe poses with the Gaussians (as MonoGS does): each training iteration also "
          "takes an Adam step on the trained keyframe's pose from the rasterizer's pose gradient. The first keyframe "
          "stays fixed (it holds the gauge). A tracking correction moves the refined pose with the tracker's, keeping "
          "the refinement's offset; the refined poses go back to tracking at the end of a run. Default false.");
  visitor("lr_pose_translation_m", options.lr_pose_translation_m,
          "Adam step size of the keyframe translation (pose_refinement) [m], >= 0. Default 2e-4.");
  visitor("lr_pose_rotation_rad", options.lr_pose_rotation_rad,
          "Adam step size of the keyframe rotation (pose_refinement) [rad], >= 0. Default 5e-4.");
  visitor("pose_refinement_max_translation_m", options.pose_refinement_max_translation_m,
          "A refinement step that would take a keyframe further than this from the tracker's pose is not applied "
          "[m], > 0. Default 0.05.");
  visitor("pose_refinement_max_rotation_rad", options.pose_refinement_max_rotation_rad,
          "The same bound on the rotation [rad], > 0. Default 0.035 (2 degrees).");
  visitor("global_sample_ratio", options.global_sample_ratio,
          "Share of training iterations that sample any stored keyframe instead of the window (keeps older parts of "
          "the map from drifting), [0, 1]. Default 0.2.");
  visitor("least_trained_first", options.least_trained_first,
          "Training picks the keyframe trained least so far (ties: the newest) within the window, and among all "
          "stored keyframes for the global share, instead of a uniform random one: keyframes seeded while mapping "
          "was behind get their share first. Default false.");
  visitor("valid_min_depth_m", options.valid_min_depth_m,
          "Depths outside [valid_min_depth_m, valid_max_depth_m] are invalid for Gaussian seeding and the loss [m]. "
          "Default 0.1.");
  visitor("valid_max_depth_m", options.valid_max_depth_m,
          "Far depth limit of the Gaussian map [m], > valid_min_depth_m. Default 6.0.");
  visitor("initial_opacity", options.initial_opacity, "Opacity of new Gaussians, (0, 1). Default 0.5 (the paper).");
  visitor("feature_samples", options.feature_samples,
          "Extra Gaussians sampled around each keypoint (the paper's densification at features), >= 0. Default 4.");
  visitor("feature_sample_radius_px", options.feature_sample_radius_px,
          "Radius of those samples around the keypoint [px] (at full resolution), > 0. Default 6.");
  visitor("coverage_stride_px", options.coverage_stride_px,
          "Grid step of the coverage of unexplained static pixels [px] (at full resolution), >= 1. Default 8.");
  visitor("coverage_alpha_threshold", options.coverage_alpha_threshold,
          "A pixel is unexplained when the rendered alpha is below this, [0, 1]. Default 0.9 (0.6 left see-through "
          "gaps where people later pass: docs/journal/benchmarks-2026.md section 4).");
  visitor("coverage_depth_error_ratio", options.coverage_depth_error_ratio,
          "... or when |rendered depth / alpha - depth| exceeds this fraction of the depth, > 0. Default 0.05.");
  visitor("coverage_fill_invalid_depth", options.coverage_fill_invalid_depth,
          "Also cover static pixels without valid depth (black screens, out of range) where nothing is rendered, at "
          "the farthest depth of the nearest measured static nodes of the coverage grid (the colour term then trains "
          "them; they have no depth term). Default true.");
}

/// The optimiser: learning rates, densify and prune, the random seed (GaussianMapperOptions).
template <typename Visitor>
void visitOptimiserOptions(GaussianMapperOptions& options, Visitor&& visitor) {
  visitor("lr_position", options.lr_position, "Adam step size of positions [m]. Default 0.0005.");
  visitor("lr_log_scale", options.lr_log_scale, "Adam step size of log-scales. Default 0.005.");
  visitor("lr_rotation", options.lr_rotation, "Adam step size of quaternions. Default 0.001.");
  visitor("lr_opacity", options.lr_opacity, "Adam step size of opacity logits. Default 0.05.");
  visitor("lr_sh_dc", options.lr_sh_dc,
          "Adam step size of the SH DC coefficients. Default 0.01 (3DGS's 0.0025 is for 30k iterations; a keyframe "
          "here gets a few tens).");
  visitor("lr_sh_rest", options.lr_sh_rest, "Adam step size of the higher SH coefficients. Default 0.000125.");
  visitor("densify_interval", options.densify_interval,
          "Densify and prune every this many iterations (0 = never), >= 0. Default 100.");
  visitor("densify_grad_threshold", options.densify_grad_threshold,
          "Mean screen-space position gradient above which a Gaussian is cloned or split [1/px], > 0. Default 0.0002.");
  visitor("densify_scale_threshold_m", options.densify_scale_threshold_m,
          "Gaussians larger than this (largest std dev) are split, smaller ones cloned [m], > 0. Default 0.02.");
  visitor("prune_min_opacity", options.prune_min_opacity,
          "Gaussians with opacity below this are pruned, [0, 1). Default 0.005.");
  visitor("prune_max_scale_m", options.prune_max_scale_m,
          "Gaussians with a std dev above this are pruned [m], > 0. Default 0.3.");
  visitor("opacity_reset_interval", options.opacity_reset_interval,
          "Reset opacities to at most 0.01 every this many iterations (0 = never), >= 0. Default 0: with a sliding "
          "window, a reset would erase the parts of the map outside the window.");
  visitor("random_seed", options.random_seed, "Seed of the keyframe sampler and of the feature samples. Default 1.");
}

/// Calls `visitor(key, field, doc)` for every field of `options`, in the order of the struct.
template <typename Visitor>
void visitOptions(GaussianMapperOptions& options, Visitor&& visitor) {
  visitScheduleOptions(options, visitor);
  visitLossAndSeedingOptions(options, visitor);
  visitOptimiserOptions(options, visitor);
}

/// Both option sets, flat (config/mapping.yaml): the cloud keys, then the Gaussian keys.
template <typename Visitor>
void visitOptions(MappingOptions& options, Visitor&& visitor) {
  visitOptions(options.cloud, visitor);
  visitOptions(options.gaussian, visitor);
}

}  // namespace dypho::mapping
