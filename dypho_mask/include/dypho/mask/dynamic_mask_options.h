#pragma once
/// \file dynamic_mask_options.h
/// Settings of the full dynamic mask (`DynamicMasker`): the segment mask from a YOLO model, the
/// motion mask from optical flow (`FlowMaskOptions`), the prior background model. The flat key
/// list (prefixes yolo_, flow_, background_) is in mask_options_fields.h.

#include <string>
#include <vector>

#include "dypho/mask/flow_mask_options.h"

namespace dypho {
namespace mask {

/// Settings of the YOLO segment/detector mask (`YoloSegmenter`).
struct YoloOptions {
  /// ONNX model file (YOLOv5/v8/v11-seg or YOLOX/YOLOv8 detector). Empty = no network (flow and
  /// background only). Default "" (none).
  std::string model_path;
  /// Output layout: auto, yolox, yolov8, yolov8_seg, yolov5_seg. Default auto (from the shapes).
  std::string layout = "auto";
  /// Network input width and height [px], multiple of 32 (the size the model was exported at,
  /// e.g. 416 for YOLOX-nano, 640 for YOLOv8-seg). Default 416.
  int input_size_px = 416;
  /// Detections below this confidence are ignored, in (0, 1). Default 0.3.
  double score_threshold = 0.3;
  /// IoU above which class-wise NMS drops the weaker box, in (0, 1]. Default 0.45.
  double nms_iou = 0.45;
  /// COCO class ids treated as dynamic, comma separated. Default person and movable things:
  /// "0,1,2,3,5,7,14,15,16,17,24,26,28,36" (person, bicycle, car, motorbike, bus, truck, bird,
  /// cat, dog, horse, backpack, handbag, suitcase, skateboard).
  std::string dynamic_classes = "0,1,2,3,5,7,14,15,16,17,24,26,28,36";
  /// Run the network on every N-th frame, >= 1; in between its mask is carried along with the
  /// optical flow. Default 1.
  int every_n_frames = 1;
  /// Run the network on a worker thread: compute() never waits for it; its newest result is
  /// carried to the current frame with the flows of the frames since. Default false.
  bool async = false;
  /// Nice increment of the asynchronous network's thread (thread_budget.h): the network takes the
  /// time the camera-rate threads leave, in [0, 19]. Default 5.
  int async_nice = 5;
  /// A network mask carried over more than this many frames since the network's input is not
  /// used: the flow-only mask (with its crowd aids, which are off while a network mask is in
  /// use) judges the frame until a fresher result comes, in [0, 1000]. The flow carries a mask
  /// well over a frame or two; older masks drift off the people and cost more than they give
  /// (Bonn crowd, network every 10th frame: 6.06 cm with every carried mask, 1.45 cm with 2).
  /// A network on every frame (sync, every_n_frames 1) is never older than 0. Default 2.
  int max_age_frames = 2;
  /// The asynchronous network's wait after results that came back older than max_age_frames
  /// (unusable: the network is slower than the frames on this machine), at most this many frames
  /// [frames]: the wait doubles with each late result (1, 2, 4, ...) and halves with each result
  /// in time (NetworkBackoff, segment_scheduler.h), so the network stops taking CPU from the
  /// camera-rate threads for results nobody uses, and comes back once it keeps up. In [0, 1000];
  /// 0 = run again as soon as the last run finished. Default 32 (about one probe per second at
  /// 30 Hz).
  int async_backoff_max_frames = 32;
  /// Detector boxes: depth extent of the object behind its nearest depth [m], > 0. Default 0.6.
  double box_depth_range_m = 0.6;

  /// Throws std::invalid_argument naming the first bad field.
  void validate() const;
  /// Parsed dynamic_classes (throws std::invalid_argument on a bad list).
  std::vector<int> dynamicClassIds() const;
};

/// Settings of the prior static-background depth model (`BackgroundModel`).
struct BackgroundOptions {
  /// Use the background model and the depth-consistency filter. Default true.
  bool enabled = true;
  /// Resolution of the model as a fraction of the input, in (0, 1]. Default 0.5.
  double scale = 0.5;
  /// tau: weight of R_d, the depth rendered from the Gaussian map at the predicted pose, in
  /// [0, 1); 0 = R_d off (nothing is rendered for the mask). Default 0 until R_d helps on real
  /// data: with 0.1 (the paper's term on) the Bonn crowd frames give 2.1 cm ATE against 1.4 cm
  /// without (docs/journal/benchmarks-2026.md, "Prior-image ablation").
  double tau = 0.0;
  /// rho: weight of the current depth on pixels the raw masks call static, in (0, 1). Default 0.3.
  double rho = 0.3;
  /// sigma_m: a neighbour's depth agrees with the background when it is not nearer than this [m],
  /// > 0. Default 0.2 (paper).
  double sigma_m = 0.2;
  /// n_m: a pixel is static when more than this many neighbours agree, >= 0. Default 9 (paper).
  int min_agreeing = 9;
  /// Side of the square neighbourhood [model px], odd >= 3 (5: 25 neighbours). Default 5.
  int window_px = 5;
  /// The consistency test forgives a depth edge this far off, as a fraction of the frame's image
  /// motion (the median flow of the pixels the ego-motion explains,
  /// FlowMaskResult::static_median_flow_px): a pixel is
  /// in front of the background only when it is in front of every background depth within that
  /// radius (BackgroundModel::retest). In [0, 2]; 0 = the pixel's own background (the paper).
  /// Default 0.25, a quarter of a frame's motion (the order of a Kinect's depth-to-colour readout
  /// offset). On TUM fr1/rpy's fast turns, with the ground-truth pose, the consistency mask of the
  /// static desk went 2.5 -> 1.1 % of the view on average (12.8 -> 8.4 % on the worst frame); the
  /// tracked ATE over the window and 14 frame-removal variants 3.70 -> 2.23 cm
  /// (docs/journal/benchmarks-2026.md, section 15).
  double motion_tolerance = 0.25;
  /// With a fresh prediction (the tracker posed the previous frame), B is warped with the relative
  /// pose fitted to the flow and the depth from it (as FlowMaskOptions::fit_rigid_motion does for
  /// a stale one), and the consistency test waits for the flow instead of running beside it. The
  /// flow's own ego-motion keeps the prediction: its homography absorbs a rotation error, B's warp
  /// does not. A constant-velocity prediction misses a hand's jerk; B's depth edges land off, the
  /// static surface in front of them fails the test, is not learnt and stays masked. Default true:
  /// on TUM fr1/rpy's static desk the offline runner's mask went from 3.2 % of the view on average
  /// (30 % on the worst frame) to 1.3 % (14 %); against the ground truth the fit's relative
  /// rotation is 0.66 deg (rms) off on fr1 and 0.25 deg on Bonn, the prediction's 0.92 and 0.31
  /// deg. Costs 1-2 ms per frame on the mask thread (offline on fr1: 8.2-8.7 -> 9.7-10.4 ms;
  /// docs/journal/benchmarks-2026.md, section 36).
  bool warp_with_flow_fit = true;
  /// Grow the dynamic regions over their depth-connected surface where the background has no
  /// value or lies behind (fills the textureless inside of a person the flow outlined; the grown
  /// pixels are not learnt into B). Default true.
  bool grow_in_depth = true;
  /// While the view moves fast (median flow of the textured pixels 6 px per frame or more,
  /// FlowMaskResult::still_camera_weight 0), a flow region grows in depth to at most this many
  /// times its own area, >= 0 (0 = no limit); one that would grow further is not grown at all.
  /// It lies on a surface reaching far beyond it, not on an object: on a fast turn before the
  /// background has a value, a flow region on a desk grew over the whole desk (TUM fr1/rpy: 4 %
  /// of the view flagged, 58 % masked). Slower, the growth is not limited: people whose flow
  /// found only their outline are filled. Default 8, >= 0 (0 = no limit): with 8 the ROS graph at
  /// 1x on TUM fr1/rpy (150 frames) answered every frame (6.6-6.7 cm) against 106-115 of 150
  /// (13.5-22.8 cm) without; offline, with the rolling-shutter model (rate prior 0.3 rad/s), the
  /// mean over the whole window, every 15th frame removed and 10 % at random went 4.00 -> 2.47 cm
  /// (docs/journal/benchmarks-2026.md, sections 13 and 14).
  double grow_max_ratio = 8.0;
  /// Flow regions that the background explains (same depth as B, no consistency pixel) are
  /// dropped only after this many updates of B since the start or reset(), >= 0: B starts as D
  /// minus a raw mask that may miss most of a person, and vetoing against that B erases the
  /// person's own flow detections. Default 10 (1/3 s at 30 Hz).
  int veto_after_updates = 10;
  /// B carried with a wrong motion: when the pixels that fail the consistency test on this frame
  /// and that neither the raw mask (flow, network) nor the previous frame's mask (carried along
  /// the flow) explains cover more than this share of the view, in [0, 1] (0 = off), every
  /// failing region the raw mask does not support (under a quarter of its pixels; the carried
  /// mask of a degraded flow supports nothing) is taken out of the mask and B takes D there
  /// outright. Otherwise B keeps such a region's wrong depth (a masked pixel is not learnt) and
  /// the mask keeps the static scene for a second or more: live on TUM fr1/rpy, where the mask's
  /// motion prior is 3-8 frames old, a wrong warp after a fast turn failed 8-22 % of the static
  /// desk at once and the mask then held 30-70 % of it for 20-30 frames. Offline on the Bonn
  /// crowd such new, unsupported failures stay under 2 % of the view (people are in the previous
  /// mask or the flow's); on the shared sequences and the generator's hard cases the offline
  /// runner's results do not change. Default 0.05 (docs/journal/benchmarks-2026.md, section 62).
  double warp_error_min_share = 0.05;

  /// Throws std::invalid_argument naming the first bad field.
  void validate() const;
};

/// All settings of `DynamicMasker`.
struct DynamicMaskOptions {
  YoloOptions yolo;            ///< segment mask (keys yolo_*)
  FlowMaskOptions flow = [] {  ///< motion mask (keys flow_*); its own margin is off here
    FlowMaskOptions f;
    f.dilate_px = 0;
    return f;
  }();
  BackgroundOptions background;  ///< background model (keys background_*)
  /// Safety margin grown around the final mask [full-res px], >= 0. Default 4.
  int margin_px = 4;
  /// With depth and the background model: the margin does not grow onto pixels whose depth lies
  /// more than background_sigma_m behind the farthest masked depth within margin_px (the wall
  /// behind a person's outline); it still grows where depth is missing or close. Halves the
  /// false-dynamic border on the synthetic sequences (docs/journal/benchmarks-2026.md section 3). Default true.
  bool margin_depth_aware = true;
  /// Connected final regions smaller than this [full-res px^2] are dropped, >= 0. Default 400.
  int min_region_area_px = 400;
  /// Raw flow regions are cut to the depth of the people in them (no halo on the wall behind):
  /// the nearest depth layer of a region, and in a crowd, where one region spans people at
  /// several depths, up to this many layers in all (a farther layer is kept when it is wider
  /// than the flow's halo and lies 0.3 m or more in front of the region's far depth), >= 1
  /// (1 = the nearest layer only). Farther layers that the established background model
  /// explains are dropped; layers are used only while the camera is still enough for the flow
  /// (median flow under 6 px per frame, full-res) and no segmentation network runs. Default 3.
  int depth_layers = 3;
  /// A frame that no mask could judge yet (the first frame after a start or a reset: no flow, no
  /// fresh network mask) is returned all dynamic, so that tracking does not build its first
  /// keyframe from people nothing has recognised yet; tracking starts one frame later.
  /// Off by default: on sequences that start with a static scene it shifts the first keyframe
  /// for no gain (TUM fr1/rpy 2.9 -> 5.7 cm). Default false.
  bool unjudged_is_dynamic = false;
  /// On the first background_veto_after_updates frames with a flow after a start or a reset (the
  /// time the background model needs to be established), a frame whose camera motion the flow did not find (fewer than
  /// flow_min_inlier_ratio of its samples follow one motion) and that carries no earlier mask is returned all dynamic
  /// and not learnt: nothing says what is static there, and people who fill the view from the first frame would carry
  /// its pose (tracking skips the frame instead). Still camera, 6 people crossing from frame 0, generator seeds 2 and
  /// 3: 8.8 and 11.4 cm ATE without, 0.12 and 0.17 cm with it. Default true.
  bool unknown_motion_is_dynamic = true;
  /// Grow the points tracking saw move on the previous frame (MovingPoints: the matches the
  /// static check found carried along with people the mask missed) over the surface they lie on,
  /// where the current depth is within 0.25 m of theirs and the background model does not explain
  /// it, so that the same people cannot carry the next pose. Default true.
  bool moving_point_seeds = true;
  /// Object permanence (object_permanence.h): a region the mask called dynamic stays dynamic on
  /// the next frames while it is still the same surface (depth within 0.15 m along the flow, in
  /// front of the background or where the background has no value) and until this many frames
  /// passed without fresh evidence (flow, background consistency, moving points) touching it; the
  /// background model does not learn it meanwhile. Flow-only mask of a still camera (see
  /// veto_flow_while_still), from the frame the background model is established
  /// (background_veto_after_updates). 0 = off, else in [1, 10000]. Default 0 (off): with the
  /// moving-point test and no flow veto while still it helped none of 24 still-camera crowd
  /// sequences, and a whole person it kept can be released on one frame (with 30, 90 or 300
  /// alike), whom the next keyframe then takes as static (8 people crossing, seed 1: 0.65 cm
  /// with 30, 0.44 cm off; docs/journal/benchmarks-2026.md section 8).
  int permanence_frames = 0;
  /// Object permanence (see permanence_frames) while the camera moves slowly: under 6 px of image
  /// motion per frame (the flow's median, FlowMaskResult::still_camera_weight > 0), where the
  /// flow's memory and depth layers work too. People who stand (turn round, wait) have no flow;
  /// without it the background model learns them and the keyframes take points on them. Faster,
  /// the ego-motion model's errors would be kept (TUM fr1/rpy 0.55 -> 5.45 cm without that limit).
  /// 0 = off, else in [1, 10000]. Default 0 (off): with 30, eleven moving-camera crowds of the
  /// generator (half-sphere and xyz, 6-8 people, 300 frames) gave mask IoU 0.835 -> 0.852 (all
  /// eleven better) at a lower false-dynamic share (4.07 -> 3.98 %), TUM fr1/rpy
  /// unchanged, the Bonn crowd 1.02 -> 0.95 cm (fifteen frame-removal inputs 1.12 -> 1.11 cm); but
  /// the crowds' ATE does not follow the mask: mean 0.91 -> 0.98 cm, the four xyz crowds 0.01-0.10
  /// cm worse each (docs/journal/benchmarks-2026.md, section 59).
  int moving_permanence_frames = 0;
  /// Flow regions that the established background model explains are dropped as flow noise also
  /// while the camera is still (median flow under 2 px per frame, and 30 % of the textured view
  /// not moving or the predicted pose moving under 5 mm per frame). Off by default: the veto is
  /// for the ego-motion model's errors, which grow with the camera's motion; with a still camera a
  /// flow region is motion, and the background that explains it has learnt a person who stood
  /// still or stood there from the start (8 people crossing a still camera's view, seed 2, with
  /// object permanence: 1.10 -> 0.53 cm). Default false.
  bool veto_flow_while_still = false;
  /// A live caller (the mask nodelet, the realtime runner) masks a frame in catch-up mode when at
  /// least this many frames wait behind it (MaskStage::process): the dense flow skips its
  /// variational refinement (FlowMaskOptions::dis_refinement_iterations) and places fewer patches
  /// (FlowMaskOptions::dis_catch_up_patch_stride): a frame costs about a quarter fewer
  /// instructions (callgrind: 103 M against 134 M on the synthetic halfsphere frames), instead of a
  /// later frame being skipped for want of time.
  /// 0 = never, else in [1, 1000]. Default 1. Offline runs never wait, so never catch up.
  int catch_up_frames_waiting = 1;

  /// Throws std::invalid_argument naming the first bad field (of any part).
  void validate() const;
  /// One line "key=value ..." with every key, for start-up logs.
  std::string toString() const;
};

}  // namespace mask
}  // namespace dypho
