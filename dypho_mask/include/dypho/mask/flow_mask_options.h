#pragma once
/// \file flow_mask_options.h
/// Settings of the optical-flow motion mask (`FlowMotionMasker`).

#include <string>

namespace dypho {
namespace mask {

/// Settings of `FlowMotionMasker`. Pixel quantities are in FULL input resolution unless stated
/// otherwise; they are converted to the reduced flow resolution internally.
struct FlowMaskOptions {
  /// Dense flow is computed at this fraction of the input resolution, in (0, 1]. Default 0.25
  /// (640x480 -> 160x120).
  double flow_scale = 0.25;
  /// A pixel is dynamic when its flow differs from the camera-induced global motion by more than
  /// this [full-res px], > 0. Default 2.0.
  double residual_threshold_px = 2.0;
  /// Connected dynamic regions smaller than this [full-res px^2] are dropped, >= 0. Default 400.
  int min_region_area_px = 400;
  /// Safety margin grown around the final mask [full-res px], >= 0. Default 8.
  int dilate_px = 8;
  /// Above this masked fraction of the image (in (0, 1]) the global-motion model is considered
  /// wrong: the result is degraded and carries the previous mask (FlowMotionMasker::compute).
  /// Default 0.6.
  double max_masked_fraction = 0.6;
  /// Radius of the morphological opening that removes speckles [full-res px], >= 0 (0 = none).
  /// Default 4.
  int open_radius_px = 4;
  /// Spacing of the grid of flow samples used to fit the global motion [full-res px], >= 1.
  /// Default 16 (1200 samples at 640x480).
  int sample_step_px = 16;
  /// RANSAC inlier threshold of the global homography fit [full-res px], > 0. Default 1.0.
  double ransac_threshold_px = 1.0;
  /// RANSAC iterations of the global homography fit, >= 1. Default 500.
  int ransac_max_iterations = 500;
  /// Minimum fraction of grid samples that must agree with the global motion, in [0, 1); below it
  /// the fit is not trusted and the result is degraded. Default 0.3.
  double min_inlier_ratio = 0.3;
  /// Flow in textureless regions (blank walls, saturated or black surfaces) is not measured but
  /// interpolated, so its residual is no evidence of motion. A flow pixel counts as textured when
  /// the RMS grey-level gradient of the reduced image over a 5x5 flow-pixel window reaches this
  /// [grey levels / flow px], >= 0 (0 = every pixel is trusted). Untextured pixels are neither
  /// used for the global-motion fit nor marked dynamic. Default 4.0.
  double min_texture_gradient = 4.0;
  /// Aperture-aware residual: on edges only the flow across the edge is measured, so only that
  /// part of the residual counts (|r|_eff^2 = r^T S r / lambda_max(S), S = 5x5 structure tensor;
  /// = |r| on corners). Removes false motion along straight texture such as floor planks.
  /// Default true.
  bool aperture_aware = true;
  /// Memory of the residual flow, in [0, 1): each pixel's residual vector is added to the
  /// previous frames' (carried along the flow, multiplied by this) before the threshold. People
  /// who move slowly (standing up, turning round, stop-and-go: under residual_threshold_px from one
  /// frame to the next) add up to residual / (1 - memory); zero-mean flow noise only to
  /// noise / sqrt(1 - memory^2). Only pixels whose residual reaches (1 - memory) *
  /// residual_threshold_px (the level whose sum can reach the threshold) keep their memory, so
  /// noise and the background uncovered behind a person start afresh. The memory would also add
  /// up the ego-motion model's own repeated errors, which grow with the camera's image motion:
  /// it is used in full while the median flow is below 2 px per frame and fades out up to 6 px
  /// (full-res). Not used while a segmentation network runs (it finds slow people by itself).
  /// 0 = frame to frame only. Default 0.7.
  double residual_memory = 0.7;
  /// When the relative pose handed to the mask is predicted from poses older than the previous
  /// frame's (a live graph's mask runs before tracking has posed the previous frame; a gap), it
  /// is first fitted to the flow and the depth (robust Gauss-Newton over the static cells, a
  /// prior on the prediction) and the background model is warped with the fit; the prediction is
  /// kept unless the fit explains clearly more cells. Such a prediction misses the hand's jerks:
  /// its translation error puts the background's depth edges off. Default true.
  bool fit_rigid_motion = true;
  /// A prediction made from older poses but one frame after the previous frame (the live graph's
  /// mask whenever tracking is slower than MaskStageOptions::previous_pose_wait_s; not after a
  /// gap, not without a prediction) whose newest pose lies at most this many frames before the
  /// previous frame (MaskPrior::pose_frames_behind) keeps the flow's ego-motion, as a fresh one
  /// does (its homography absorbs the rotation error): only the background is warped with the
  /// motion fitted to the flow (BackgroundOptions::warp_with_flow_fit). Older ones, and every one
  /// with 0, have the fit (fit_rigid_motion) serve both. In [0, 1000]. Default 1: with every pose
  /// exactly one frame late (dypho_run_dataset --late-mask-poses) it gains (fr1/rpy's fifteen
  /// frame-removal inputs 0.96 -> 0.88 cm, Bonn crowd's 1.47 -> 1.17), and through the live graph
  /// at 1x, where predictions are also older, on fr1/rpy 0.85 -> 0.78 cm and on Bonn crowd 1.26 ->
  /// 1.09 cm (twenty and six runs a side); keeping every age (1000) lost on fr1/rpy through the
  /// graph (0.81 -> 0.88 cm). Offline the predictions are fresh: no effect.
  int stale_prediction_kept_frames_behind = 1;
  /// With the previous frame's mask at hand, the global motion is fitted again without its pixels
  /// and replaces the fit on every sample when it explains more of the pixels outside that mask
  /// by this share of them, in [0, 1) (0 = only when the first fit failed or follows the masked
  /// pixels). With several motions in view (people walking apart, the previous mask on some of
  /// them) the first fit can settle on people or between them and mark the static scene as
  /// moving: a wall's marker beside a passing head, Bonn crowd. Default 0.05.
  double refit_without_previous_margin = 0.05;
  /// Use OpenCV's DIS PRESET_ULTRAFAST instead of PRESET_FAST (faster, noisier). Default false.
  bool ultrafast = false;
  /// Variational refinement iterations of DIS on every pyramid level, >= 0; replaces the
  /// preset's count (FAST 5, ULTRAFAST 0). Each iteration costs about as much as a fifth of the
  /// whole FAST flow at 160x120; beyond 2 the mask does not change measurably
  /// (bench/mask_synth_bench, docs/journal/benchmarks-2026.md section 3). Default 2.
  int dis_refinement_iterations = 2;
  /// Catch-up mode (FlowMotionMasker::setCatchingUp: a live caller fell behind): DIS places its
  /// patches this far apart [flow px], in [1, 64] (the presets: FAST 4, ULTRAFAST 5). With 6 (and 8
  /// descent iterations) a catch-up frame's flow takes a third of a normal frame's instructions,
  /// and the whole mask 103 M against 134 M (120 M with the refinement skipped alone; callgrind,
  /// synthetic halfsphere frames); the masks meet the bounds as before
  /// (MaskRegression.MeetsTheIssueBoundsWhileCatchingUp). 8 failed a moving square's bound
  /// (FlowMotionMasker.CatchUpModeSkipsTheRefinementAndStillFindsTheMover). Default 6.
  int dis_catch_up_patch_stride = 6;
  /// Catch-up mode: gradient-descent iterations of each DIS patch, in [1, 100] (the presets: FAST
  /// 16, ULTRAFAST 12). Default 8.
  int dis_catch_up_iterations = 8;

  /// Throws std::invalid_argument naming the first field that is out of range and its range.
  void validate() const;
  /// One line "key=value ..." with every field, for start-up logs.
  std::string toString() const;
};

}  // namespace mask
}  // namespace dypho
