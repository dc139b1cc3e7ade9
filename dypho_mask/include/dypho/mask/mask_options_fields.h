#pragma once
/// \file mask_options_fields.h
/// The list of mask option keys, written once: parameter readers (ROS private params, YAML
/// files) and printers visit the fields through `visitOptions`. Keep it in the order of the
/// structs. `DynamicMaskOptions` is flattened with the prefixes yolo_, flow_, background_ (a key
/// that already starts with its prefix, flow_scale, keeps its name).

#include <string>
#include <utility>

#include "dypho/mask/dynamic_mask_options.h"
#include "dypho/mask/flow_mask_options.h"

namespace dypho::mask {

/// Calls `visitor(key, field, doc)` for every field of `options`.
template <typename Visitor>
void visitOptions(FlowMaskOptions& options, Visitor&& visitor) {
  visitor(
      "flow_scale", options.flow_scale,
      "Dense flow is computed at this fraction of the input resolution, in (0, 1]. Default 0.25 (640x480 -> 160x120).");
  visitor("residual_threshold_px", options.residual_threshold_px,
          "A pixel is dynamic when its flow differs from the camera-induced global motion by more than this [full-res "
          "px], > 0. Default 2.0.");
  visitor("min_region_area_px", options.min_region_area_px,
          "Connected dynamic regions smaller than this [full-res px^2] are dropped, >= 0. Default 400.");
  visitor("dilate_px", options.dilate_px, "Safety margin grown around the final mask [full-res px], >= 0. Default 8.");
  visitor("max_masked_fraction", options.max_masked_fraction,
          "Above this masked fraction of the image (in (0, 1]) the global-motion model is considered wrong: the result "
          "is degraded and carries the previous frame's mask along the flow. Default 0.6.");
  visitor("open_radius_px", options.open_radius_px,
          "Radius of the morphological opening that removes speckles [full-res px], >= 0 (0 = none). Default 4.");
  visitor("sample_step_px", options.sample_step_px,
          "Spacing of the grid of flow samples used to fit the global motion [full-res px], >= 1. Default 16 (1200 "
          "samples at 640x480).");
  visitor("ransac_threshold_px", options.ransac_threshold_px,
          "RANSAC inlier threshold of the global homography fit [full-res px], > 0. Default 1.0.");
  visitor("ransac_max_iterations", options.ransac_max_iterations,
          "RANSAC iterations of the global homography fit, >= 1. Default 500.");
  visitor("min_inlier_ratio", options.min_inlier_ratio,
          "Minimum fraction of grid samples that must agree with the global motion, in [0, 1); below it the fit is not "
          "trusted and the result is degraded. Default 0.3.");
  visitor("min_texture_gradient", options.min_texture_gradient,
          "Flow in textureless regions is interpolated, not measured, so its residual is no evidence of motion. A flow "
          "pixel counts as textured when the RMS grey-level gradient of the reduced image over a 5x5 flow-pixel window "
          "reaches this [grey levels / flow px], >= 0 (0 = every pixel is trusted). Untextured pixels are neither used "
          "for the global-motion fit nor marked dynamic. Default 4.0.");
  visitor("aperture_aware", options.aperture_aware,
          "Aperture-aware residual: on edges only the flow across the edge is measured, so only that part of the "
          "residual counts (|r|_eff^2 = r^T S r / lambda_max(S), S = 5x5 structure tensor; = |r| on corners). Removes "
          "false motion along straight texture such as floor planks. Default true.");
  visitor("residual_memory", options.residual_memory,
          "Memory of the residual flow, in [0, 1): each pixel's residual vector is added to the previous frames' "
          "(carried along the flow, multiplied by this) before the threshold. People who move slowly (standing up, "
          "turning round, stop-and-go: under residual_threshold_px from one frame to the next) add up to residual / (1 "
          "- memory); zero-mean flow noise only to noise / sqrt(1 - memory^2). Only pixels whose residual reaches (1 - "
          "memory) * residual_threshold_px (the level whose sum can reach the threshold) keep their memory, so noise "
          "and the background uncovered behind a person start afresh. The memory would also add up the ego-motion "
          "model's own repeated errors, which grow with the camera's image motion: it is used in full while the median "
          "flow is below 2 px per frame and fades out up to 6 px (full-res). Not used while a segmentation network "
          "runs (it finds slow people by itself). 0 = frame to frame only. Default 0.7.");
  visitor(
      "fit_rigid_motion", options.fit_rigid_motion,
      "When the relative pose handed to the mask is predicted from poses older than the previous frame's (a live "
      "graph's mask runs before tracking has posed the previous frame; a gap), it is first fitted to the flow and "
      "the depth (robust Gauss-Newton over the static cells, a prior on the prediction) and the background model is "
      "warped with the fit; the prediction is kept unless the fit explains clearly more cells. Such a prediction "
      "misses the hand's jerks: its translation error puts the background's depth edges off (TUM fr1/rpy with poses "
      "3 frames old: 11.4 % of the static view masked, 2.0 % fitted). Default true.");
  visitor("stale_prediction_kept_frames_behind", options.stale_prediction_kept_frames_behind,
          "A prediction made from older poses but one frame after the previous frame (the live graph's mask whenever "
          "tracking is slower than previous_pose_wait_s; not after a gap, not without a prediction) whose newest "
          "pose lies at most this many frames before the previous frame keeps the flow's ego-motion, as a fresh one "
          "does (its homography absorbs the rotation error): only the background is warped with the motion fitted "
          "to the flow (background_warp_with_flow_fit). Older ones, and every one with 0, have the fit "
          "(fit_rigid_motion) serve both. In [0, 1000]. Default 1 (keeping every age lost on TUM fr1/rpy live).");
  visitor("refit_without_previous_margin", options.refit_without_previous_margin,
          "With the previous frame's mask at hand, the global motion is fitted again without its pixels and replaces "
          "the fit on every sample when it explains more of the pixels outside that mask by this share of them, in "
          "[0, 1) (0 = only when the first fit failed or follows the masked pixels). With several motions in view "
          "(people walking apart, the previous mask on some of them) the first fit can settle on people or between "
          "them and mark the static scene as moving. Default 0.05.");
  visitor("ultrafast", options.ultrafast,
          "Use OpenCV's DIS PRESET_ULTRAFAST instead of PRESET_FAST (faster, noisier). Default false.");
  visitor("dis_refinement_iterations", options.dis_refinement_iterations,
          "Variational refinement iterations of DIS on every pyramid level, in [0, 100]; replaces the preset's count "
          "(FAST 5, ULTRAFAST 0). Beyond 2 the mask does not change measurably. Default 2.");
  visitor(
      "dis_catch_up_patch_stride", options.dis_catch_up_patch_stride,
      "In catch-up mode (catch_up_frames_waiting: a live caller fell behind) DIS places its patches this far apart "
      "[flow px], in [1, 64] (the presets: FAST 4, ULTRAFAST 5); with 6 and 8 descent iterations a catch-up frame's "
      "flow takes a third of the instructions and the masks still meet the issue's bounds. Default 6.");
  visitor("dis_catch_up_iterations", options.dis_catch_up_iterations,
          "In catch-up mode: gradient-descent iterations of each DIS patch, in [1, 100] (the presets: FAST 16, "
          "ULTRAFAST 12). Default 8.");
}

/// Calls `visitor(key, field, doc)` for every field of `options` (keys without prefix).
template <typename Visitor>
void visitOptions(YoloOptions& options, Visitor&& visitor) {
  visitor("model_path", options.model_path,
          "ONNX model file (YOLOv5/v8/v11-seg or YOLOX/YOLOv8 detector). Empty = no network (flow and background "
          "only). Default \"\" (none).");
  visitor("layout", options.layout,
          "Output layout: auto, yolox, yolov8, yolov8_seg, yolov5_seg. Default auto (from the output shapes).");
  visitor("input_size_px", options.input_size_px,
          "Network input width and height [px], multiple of 32 (the size the model was exported at: 416 for "
          "YOLOX-nano, 640 for YOLOv8-seg). Default 416.");
  visitor("score_threshold", options.score_threshold,
          "Detections below this confidence are ignored, in (0, 1). Default 0.3.");
  visitor("nms_iou", options.nms_iou, "IoU above which class-wise NMS drops the weaker box, in (0, 1]. Default 0.45.");
  visitor("dynamic_classes", options.dynamic_classes,
          "COCO class ids treated as dynamic, comma separated. Default person, bicycle, car, motorbike, bus, truck, "
          "bird, cat, dog, horse, backpack, handbag, suitcase, skateboard.");
  visitor("every_n_frames", options.every_n_frames,
          "Run the network on every N-th frame, >= 1; in between its mask is carried along with the optical flow. "
          "Default 1.");
  visitor("async", options.async,
          "Run the network on a worker thread; its newest result is carried to the current frame with the optical "
          "flow. Default false.");
  visitor("async_nice", options.async_nice,
          "Nice increment of the asynchronous network's thread: the network takes the time the camera-rate threads "
          "leave, in [0, 19]. Default 5.");
  visitor("max_age_frames", options.max_age_frames,
          "A network mask carried over more than this many frames since the network's input is not used: the flow-only "
          "mask with its crowd aids judges the frame until a fresher result comes, in [0, 1000]. Older carried masks "
          "drift off the people (Bonn crowd, network every 10th frame: 6.06 cm with every carried mask, 1.45 cm with "
          "2; the live graph at 1x on 2 cores, where results are 3-6 frames old: see docs/journal/benchmarks-2026.md "
          "section 8). Default 2.");
  visitor("async_backoff_max_frames", options.async_backoff_max_frames,
          "After results of the asynchronous network that came back older than yolo_max_age_frames (the network is "
          "slower than the frames on this machine), its next run waits 1, 2, 4, ... frames, at most this many; each "
          "result in time halves it. The network then stops taking CPU from the camera-rate threads for results nobody "
          "uses, and comes back once it keeps up. In [0, 1000]; 0 = run again as soon as the last run finished. "
          "Default 32 (about one probe per second at 30 Hz).");
  visitor("box_depth_range_m", options.box_depth_range_m,
          "Detector boxes are segmented with depth: depth extent of the object behind its nearest depth [m], > 0. "
          "Default 0.6.");
}

/// Calls `visitor(key, field, doc)` for every field of `options` (keys without prefix).
template <typename Visitor>
void visitOptions(BackgroundOptions& options, Visitor&& visitor) {
  visitor("enabled", options.enabled,
          "Use the prior static-background depth model and the depth-consistency filter. Default true.");
  visitor("scale", options.scale,
          "Resolution of the background model as a fraction of the input, in (0, 1]. Default 0.5.");
  visitor("tau", options.tau,
          "tau: weight of R_d, the depth rendered from the Gaussian map at the predicted pose (the paper's prior-image "
          "term), in [0, 1); 0 = off, nothing is rendered for the mask. Default 0 (on the Bonn crowd frames 0.1 gives "
          "2.1 cm ATE against 1.4 cm; docs/journal/benchmarks-2026.md).");
  visitor("rho", options.rho,
          "rho: weight of the current depth on pixels the raw masks call static, in (0, 1). Default 0.3.");
  visitor("sigma_m", options.sigma_m,
          "sigma_m: a neighbour's depth agrees with the background when it is not nearer than this [m], > 0. Default "
          "0.2 (paper).");
  visitor("min_agreeing", options.min_agreeing,
          "n_m: a pixel is static when more than this many neighbours agree, >= 0. Default 9 (paper).");
  visitor("window_px", options.window_px,
          "Side of the square neighbourhood [background px], odd >= 3. Default 5 (25 neighbours).");
  visitor("motion_tolerance", options.motion_tolerance,
          "The consistency test forgives a depth edge this far off, as a fraction of the frame's image motion "
          "(the static scene's median flow): a pixel is in front of the background only when it is in front of every "
          "background depth within "
          "that radius (a fast turn puts depth edges a few pixels off), in [0, 2]; 0 = the pixel's own background "
          "(the paper). Default 0.25 (measured: docs/journal/benchmarks-2026.md, section 15).");
  visitor("warp_with_flow_fit", options.warp_with_flow_fit,
          "With a fresh prediction (the tracker posed the previous frame), the background is warped with the relative "
          "pose fitted to the flow and the depth from it, and the consistency test waits for the flow; the flow's "
          "ego-motion keeps the prediction. A constant-velocity prediction misses a hand's jerk and puts the "
          "background's depth edges off: the static surface in front of them stays masked. Default true (TUM "
          "fr1/rpy's static desk: 3.2 % of the view masked -> 1.3 %; docs/journal/benchmarks-2026.md, section 36).");
  visitor("grow_in_depth", options.grow_in_depth,
          "Grow the dynamic regions over their depth-connected surface where the background has no value or lies "
          "behind (fills the textureless inside of a person the flow outlined; grown pixels are not learnt into the "
          "background). Default true.");
  visitor(
      "grow_max_ratio", options.grow_max_ratio,
      "While the view moves fast (median flow 6 px per frame or more), a flow region grows in depth to at most "
      "this many times its own area, >= 0 (0 = no limit); one that would grow further is not grown at all: it lies "
      "on a surface reaching far beyond it (a desk on a fast turn before the background has a value), not on an "
      "object. Slower, the growth is not limited. Default 8 (measured: docs/journal/benchmarks-2026.md, sections 13 "
      "and 14).");
  visitor(
      "veto_after_updates", options.veto_after_updates,
      "Flow regions that the background explains (same depth, no consistency pixel) are dropped only after this many "
      "background updates since the start or a reset, >= 0: B starts as D minus a raw mask that may miss most of a "
      "person, and vetoing against that B erases the person's own flow detections. Default 10 (1/3 s at 30 Hz).");
  visitor("warp_error_min_share", options.warp_error_min_share,
          "When the consistency failures of a frame that neither the raw mask (flow, network) nor the previous "
          "frame's mask carried along the flow explains cover more than this share of the view, the background was "
          "carried with a wrong motion: each failing region the raw mask does not support (under a quarter of it) is "
          "unmasked and the background takes the current depth there. Otherwise the masked static scene is never "
          "learnt and stays masked (live on TUM fr1/rpy after fast turns: 30-70 % of the desk for 20-30 frames). In "
          "[0, 1]; 0 = off. Default 0.05.");
}

namespace detail {
/// Forwards to `visitor` with `prefix` prepended to each key (unless the key already has it).
template <typename Visitor>
struct PrefixedVisitor {
  Visitor& visitor;
  std::string prefix;
  template <typename T>
  void operator()(const std::string& key, T& value, const char* doc) {
    visitor(key.compare(0, prefix.size(), prefix) == 0 ? key : prefix + key, value, doc);
  }
};
}  // namespace detail

/// Calls `visitor(key, field, doc)` for every field of `options`, flattened with prefixes.
template <typename Visitor>
void visitOptions(DynamicMaskOptions& options, Visitor&& visitor) {
  visitOptions(options.yolo, detail::PrefixedVisitor<Visitor>{visitor, "yolo_"});
  visitOptions(options.flow, detail::PrefixedVisitor<Visitor>{visitor, "flow_"});
  visitOptions(options.background, detail::PrefixedVisitor<Visitor>{visitor, "background_"});
  visitor("margin_px", options.margin_px, "Safety margin grown around the final mask [full-res px], >= 0. Default 4.");
  visitor("margin_depth_aware", options.margin_depth_aware,
          "With depth and the background model: the margin does not grow onto pixels whose depth lies more than "
          "background_sigma_m behind the farthest masked depth within margin_px (the wall behind a person's outline); "
          "it still grows where depth is missing or close. Default true.");
  visitor("min_region_area_px", options.min_region_area_px,
          "Connected final regions smaller than this [full-res px^2] are dropped, >= 0. Default 400.");
  visitor("depth_layers", options.depth_layers,
          "Raw flow regions are cut to the depth of the people in them (no halo on the wall behind): the nearest depth "
          "layer of a region, and in a crowd, where one region spans people at several depths, up to this many layers "
          "in all (a farther layer is kept when it is wider than the flow's halo and lies 0.3 m or more in front of "
          "the region's far depth), >= 1 (1 = the nearest layer only). Farther layers that the established background "
          "model explains are dropped; layers are used only while the camera is still enough for the flow (median flow "
          "under 6 px per frame, full-res) and no segmentation network runs. Default 3.");
  visitor("unjudged_is_dynamic", options.unjudged_is_dynamic,
          "A frame that no mask could judge yet (the first frame after a start or a reset: no flow, no fresh network "
          "mask) is returned all dynamic, so that tracking does not build its first keyframe from people nothing has "
          "recognised yet; tracking starts one frame later. Off by default: on sequences that start with a static "
          "scene it shifts the first keyframe for no gain (TUM fr1/rpy 2.9 -> 5.7 cm). Default false.");
  visitor("unknown_motion_is_dynamic", options.unknown_motion_is_dynamic,
          "On the first background_veto_after_updates frames with a flow after a start or a reset (the time the "
          "background model needs to be established), a frame whose camera motion the flow did not find (fewer than "
          "flow_min_inlier_ratio of its samples follow one motion) and that carries no earlier mask is returned all "
          "dynamic and not learnt: nothing says what is static there, and people who fill the view from the first "
          "frame would carry its pose (tracking skips the frame instead). Still camera, 6 people crossing from frame "
          "0, generator seeds 2 and 3: 8.8 and 11.4 cm ATE without, 0.12 and 0.17 cm with it. Default true.");
  visitor("moving_point_seeds", options.moving_point_seeds,
          "Grow the points tracking saw move on the previous frame (MovingPoints: the matches the static check found "
          "carried along with people the mask missed) over the surface they lie on, where the current depth is within "
          "0.25 m of theirs and the background model does not explain it, so that the same people cannot carry the "
          "next pose. Default true.");
  visitor("permanence_frames", options.permanence_frames,
          "Object permanence (object_permanence.h): a region the mask called dynamic stays dynamic on the next frames "
          "while it is still the same surface (depth within 0.15 m along the flow, in front of the background or where "
          "the background has no value) and until this many frames passed without fresh evidence (flow, background "
          "consistency, moving points) touching it; the background model does not learn it meanwhile. Flow-only mask "
          "of a still camera (see veto_flow_while_still), from the frame the background model is established "
          "(background_veto_after_updates). 0 = off, else in [1, 10000]. Default 0 (off): with the moving-point test "
          "and no flow veto while still it helped none of 24 still-camera crowd sequences, and a whole person it kept "
          "can be released on one frame (with 30, 90 or 300 alike), whom the next keyframe then takes as static (8 "
          "people crossing, seed 1: 0.65 cm with 30, 0.44 cm off).");
  visitor("moving_permanence_frames", options.moving_permanence_frames,
          "Object permanence (see permanence_frames) while the camera moves slowly: under 6 px of image motion per "
          "frame (the flow's median), where the flow's memory and depth layers work too. People who stand (turn round, "
          "wait) have no flow; without it the background model learns them and the keyframes take points on them. 0 = "
          "off, else in [1, 10000]. Default 0 (off): with 30, eleven moving-camera crowds of the generator gave mask "
          "IoU 0.835 -> 0.852 at a lower false-dynamic share (4.07 -> 3.98 %), the Bonn crowd 1.02 -> 0.95 cm, TUM "
          "fr1/rpy unchanged; but the crowds' ATE does not follow the mask (mean 0.91 -> 0.98 cm, the four xyz crowds "
          "0.01-0.10 cm worse each) (docs/journal/benchmarks-2026.md, section 59).");
  visitor("veto_flow_while_still", options.veto_flow_while_still,
          "Flow regions that the established background model explains are dropped as flow noise also while the camera "
          "is still (median flow under 2 px per frame, and 30 % of the textured view not moving or the predicted pose "
          "moving under 5 mm per frame). Off by default: the veto is for the ego-motion model's errors, which grow "
          "with the camera's motion; with a still camera a flow region is motion, and the background that explains it "
          "has learnt a person who stood still or stood there from the start (8 people crossing a still camera's view, "
          "seed 2, with object permanence: 1.10 -> 0.53 cm). Default false.");
  visitor("catch_up_frames_waiting", options.catch_up_frames_waiting,
          "A live caller (the mask nodelet, the realtime runner) masks a frame in catch-up mode when at least this "
          "many frames wait behind it: the dense flow skips its variational refinement "
          "(flow_dis_refinement_iterations) and places fewer patches (flow_dis_catch_up_patch_stride), about a "
          "quarter of the mask's instructions per frame, instead of a later frame being skipped for want of time. 0 = "
          "never, else in [1, 1000]. Default 1. Offline runs never "
          "wait, so never catch up.");
}

}  // namespace dypho::mask
