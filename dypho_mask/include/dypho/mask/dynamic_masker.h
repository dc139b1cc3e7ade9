#pragma once
/// \file dynamic_masker.h
/// The dynamic mask of the paper's "Dynamic Process": raw mask = segment mask (YOLO, optional)
/// OR motion mask (dense flow with the camera's own motion removed), refined by the prior static
/// background model and its neighbourhood depth-consistency test, cleaned and grown by a margin.
///
/// Mask convention at this API edge: CV_8UC1, 255 = dynamic, 0 = static (the paper writes the
/// inverse, 1 = static); on topics `mono8` with the same values.
///
/// Per frame: (1) flow mask (flow_motion_masker.h; with `prior.T_prev_cur`, depth and a valid
/// camera the ego-motion is predicted from depth, else a global homography is removed);
/// (2) segment mask from the scheduler (network every N-th frame or async, carried by the flow in
/// between); (3) at background resolution: consistency mask of D_i against the warped B_{i-1}
/// (+ rendered depth), final = consistency OR raw, then B_i is updated (background_model.h);
/// (4) open + small-region removal + margin, upsampled to the input size.
/// The consistency test of (3) warps B with the relative pose the flow's rigid fit found (with a
/// prediction: BackgroundOptions::warp_with_flow_fit, FlowMaskOptions::fit_rigid_motion) and
/// then runs after (1); with the fit off for the frame's kind of prediction, or none yet, it needs
/// no flow and runs beside (1) on OpenCV's thread pool (cv::parallel_for_ with two tasks; serially
/// when cv::getNumThreads() is 1).
/// Degraded modes (documented, never a crash): no depth or a size mismatch -> no background
/// model and no depth-based ego-motion (flow homography + segment boxes painted whole); depth all
/// zero -> the background model has nothing to compare (raw masks only); no/failed network ->
/// flow + background only (warning in `message` on the first frame, and in status()).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mask/background_model.h"
#include "dypho/mask/box_depth_segmenter.h"
#include "dypho/mask/dynamic_mask_options.h"
#include "dypho/mask/flow_motion_masker.h"
#include "dypho/mask/mask_cleaner.h"

namespace dypho {
namespace mask {

class ObjectPermanence;
class SegmentScheduler;

/// What other modules know about this frame (all optional).
struct MaskPrior {
  /// Predicted pose of the current camera in the previous camera frame (constant velocity from
  /// tracking): p_prev = T_prev_cur * p_cur.
  std::optional<Eigen::Isometry3d> T_prev_cur;
  /// `T_prev_cur` extrapolates the previous frame's own tracked pose by one frame interval (what
  /// a caller that tracks every frame before masking the next hands over): it is used as is.
  /// Otherwise (poses older than the previous frame, as in a live graph whose mask runs ahead of
  /// tracking; a gap) it is fitted to the flow first (FlowMaskOptions::fit_rigid_motion).
  bool prediction_fresh = false;
  /// Frame intervals between the newest tracked pose `T_prev_cur` was predicted from and the
  /// previous frame: 0 = the previous frame's own pose; 1 = the pose before it (tracking one frame
  /// behind the mask); frames dropped in between count; -1 = not known, taken as too old to keep
  /// (FlowMaskOptions::stale_prediction_kept_frames_behind).
  int pose_frames_behind = -1;
  /// Frames are missing before this one (its stamp is more than 1.5 frame intervals after the
  /// previous frame's: skipped or dropped ones). When the flow does not confirm the camera's
  /// motion across the gap and B, carried with the prediction, fails the test on far more of the
  /// view than the last mask held (DynamicMasker::backgroundLostTheView), B starts again from this
  /// frame: carried with a wrong guess it marks the static view dynamic, and keeps it so.
  bool after_gap = false;
  /// R_d(G, T_{i-1} delta T): CV_32FC1 depth [m] rendered from the map at the predicted current
  /// pose, at the input size or at workingSize() (no resampling then); empty = none (0/NaN
  /// pixels = no value).
  cv::Mat rendered_depth_m;
  /// Points tracking saw move (MovingPoints), carried into the current camera optical frame [m]
  /// (DynamicMaskOptions::moving_point_seeds); empty = none.
  std::vector<cv::Point3f> moving_points_camera_m;
  /// Frames wait behind this one (DynamicMaskOptions::catch_up_frames_waiting): the flow runs
  /// without its variational refinement.
  bool catching_up = false;
};

/// Output of `DynamicMasker::compute`. All masks CV_8UC1, input size, 255 = dynamic.
struct MaskResult {
  cv::Mat mask;                  ///< final mask
  cv::Mat raw_flow_mask;         ///< thresholded flow residual (empty when no flow this frame)
  cv::Mat raw_segment_mask;      ///< segment/detector mask in use (empty when none)
  cv::Mat consistency_mask;      ///< background depth-consistency mask (empty when not run)
  double masked_fraction = 0.0;  ///< share of `mask` that is dynamic, [0, 1]
  /// True when part of the pipeline could not run this frame (bad input, flow fit failed);
  /// the mask is then what the remaining parts give (possibly empty). `message` says why.
  bool degraded = false;
  /// Set by MaskStage only: the frame's stamp was repeated or late (stamp_gate.h); it was not
  /// masked, `mask` is empty and `message` says why.
  bool dropped = false;
  /// No mask could judge this frame (first frame after a start or reset, no fresh network mask):
  /// the mask is all static, or all dynamic with DynamicMaskOptions::unjudged_is_dynamic. A network
  /// that ran on the frame judged it, even when it found nobody.
  bool unjudged = false;
  std::string message;                ///< why degraded, warnings, "first frame"
  bool ego_motion_from_pose = false;  ///< flow used depth + pose (false: homography fallback)
  bool rendered_depth_used = false;   ///< R_d entered the background model B_i on this frame
  bool segment_fresh = false;         ///< the network ran on this frame
  int segment_age_frames = 0;         ///< frames the segment mask was carried
  bool network_started = false;       ///< the network was started (async) or run (sync) on this frame
  /// An asynchronous network result came back on this frame already older than
  /// YoloOptions::max_age_frames (not used; the network waits longer before its next run).
  bool network_result_late = false;
  std::vector<cv::Rect> detection_boxes;  ///< boxes behind the segment mask (image px)
  double flow_ms = 0.0;                   ///< flow masker, whole [ms]
  double segment_ms = 0.0;                ///< network (sync) + carrying [ms]
  /// background model + combination + clean-up [ms]; when its consistency test runs beside the
  /// flow, flow_ms + background_ms can exceed the wall time (total_ms - segment_ms)
  double background_ms = 0.0;
  double total_ms = 0.0;  ///< whole compute(), wall time [ms]
};

/// True when the camera stands still on the frame of `flow`: the median flow of the textured
/// pixels is under 2 px (full-res), and either at least 30 % of them move less than 0.5 px
/// (FlowMaskResult::quiet_flow_share) or the predicted motion `T_prev_cur` translates less than
/// 5 mm. False without a flow. Decides DynamicMaskOptions::veto_flow_while_still and
/// permanence_frames.
bool cameraStill(const FlowMaskResult& flow, const std::optional<Eigen::Isometry3d>& T_prev_cur);

/// Computes the dynamic mask frame by frame. Not thread-safe; one instance per image stream.
class DynamicMasker {
 public:
  /// Validates `options` (std::invalid_argument). Loads the YOLO model when configured; a model
  /// problem is not an error (see status()).
  explicit DynamicMasker(const DynamicMaskOptions& options);
  ~DynamicMasker();
  DynamicMasker(const DynamicMasker&) = delete;
  DynamicMasker& operator=(const DynamicMasker&) = delete;

  /// Mask of `frame` (bgr CV_8UC3 or CV_8UC1; depth CV_32FC1 of the same size or empty).
  MaskResult compute(const RgbdFrame& frame, const MaskPrior& prior = {});

  /// The part of compute() that needs no prior: the dense flow of `frame`
  /// (FlowMotionMasker::prepareFlow), in catch-up mode when `catching_up`. A caller may then wait
  /// for the pose the prior is made from; compute() of the same frame follows (with the same
  /// catching_up) and gives what it gives without this call.
  void prepareFlow(const RgbdFrame& frame, bool catching_up);

  /// Size at which the background model B_i works (input size times background.scale): R_d is
  /// best rendered at this size.
  cv::Size workingSize(const cv::Size& input) const;

  /// Forgets all history (flow, carried segment mask, background model).
  void reset();

  /// State of the segment network: ready, or why not (no model / file missing / bad layout).
  const std::string& segmentStatus() const;
  bool segmentReady() const;
  const DynamicMaskOptions& options() const { return options_; }
  /// The background model's B (CV_32FC1 [m] at background resolution, 0 = none).
  const cv::Mat& backgroundDepth() const { return background_.background(); }
  /// The prior Q the last consistency test used (CV_32FC1 [m] at background resolution, 0 = none).
  const cv::Mat& backgroundPrior() const { return background_.prior(); }

 private:
  struct FrameState;  ///< one frame as compute() hands it from step to step (dynamic_masker.cpp)

  /// Step 1: the flow masker's motion mask (flow, ego-motion) into f.flow and the consistency
  /// test (when f.run_background), in one of the three ways below.
  void computeMotionAndConsistency(FrameState& f);
  /// Without a prediction or with a stale one (FlowMaskOptions::fit_rigid_motion; not one
  /// FlowMaskOptions::stale_prediction_kept_frames_behind keeps): the flow's
  /// ego-motion and B's warp both use the motion fitted to the flow from the guess; B starts
  /// again when the guess put it off the view.
  void motionFittedFromAGuess(FrameState& f, bool no_prediction);
  /// With a fresh prediction, or a stale one stale_prediction_kept_frames_behind keeps
  /// (BackgroundOptions::warp_with_flow_fit): the flow from the prediction, then the test with B
  /// warped with the motion fitted to the flow.
  void motionThenConsistencyWithTheFit(FrameState& f);
  /// Otherwise: the flow beside the test on OpenCV's pool; rethrows either task's exception.
  void motionBesideConsistency(FrameState& f);
  /// The consistency test of D_i against the prior: depth_small_, rendered_small_ and
  /// consistency_small_ at background resolution; f.test_ms, f.rendered_ignored.
  void testAgainstBackground(FrameState& f);
  /// True when the consistency test (consistency_small_) failed a share of the view larger by
  /// kLostViewShare than the previous frame's whole mask: B was carried to the view with a
  /// motion that does not fit it.
  bool backgroundLostTheView() const;
  /// Share of the view [0, 1] (see backgroundLostTheView): fr1/rpy's static desk after a 17 deg
  /// turn across ten missing frames failed on 59 % after 1 % (section 30 of the benchmarks).
  static constexpr double kLostViewShare = 0.3;
  /// Copies the motion mask's outputs and notes into `result`; false when it has no mask
  /// (unusable input: `result` is final).
  bool reportMotion(const FrameState& f, MaskResult& result);
  /// Step 2: the segment mask of this frame into f.seg (and its outputs into `result`).
  void computeSegment(FrameState& f, MaskResult& result);
  /// True when the start rules (unjudged_is_dynamic, unknown_motion_is_dynamic) made `result`
  /// all dynamic; counts the flow frames.
  bool startsAllDynamic(const FrameState& f, MaskResult& result);
  /// Step 3 with the background model: raw mask, veto, consistency, seeds, permanence and depth
  /// growth fused at background resolution, B_i updated, `result` finished.
  void fuseAtBackground(const FrameState& f, MaskResult& result);
  /// raw_small_ = the flow mask cut to depth layers (farther layers the background explains
  /// dropped) OR the segment mask (seg_small_), at background resolution.
  void cutRawMaskAtBackground(const FrameState& f);
  /// raw_small_ = its flow part less the regions the established background explains (while
  /// the camera moves, or always with veto_flow_while_still) OR seg_small_; returns cameraStill().
  bool vetoFlowOnBackground(const FrameState& f);
  /// The object permanence that serves this frame (see DynamicMaskOptions::permanence_frames and
  /// moving_permanence_frames), null when none does; `still` = cameraStill() of the frame.
  ObjectPermanence* activePermanence(const FrameState& f, bool still) const;
  /// BackgroundOptions::warp_error_min_share: when the frame's new, unsupported consistency
  /// failures show that B was carried with a wrong motion, takes the unsupported failure regions
  /// out of consistency_small_ into relearn_small_ and returns true.
  bool dropBackgroundWarpError(const FrameState& f);
  /// Both object permanences forget what they kept.
  void resetPermanence();
  /// Step 3 without the background model: flow mask OR segment mask at input size, finished.
  void fuseAtInput(const FrameState& f, MaskResult& result);
  /// ORs into combined_ the surfaces grown from the moving points (moving_point_seeds).
  void addMovingPointSeeds(const std::vector<cv::Point3f>& p_camera_m, const CameraIntrinsics& camera_small);
  /// The frame says nothing about what is static: `result` all dynamic (255), `why` added to its
  /// message, and nothing carried into the next frame.
  void allDynamic(const cv::Size& size, const std::string& why, MaskResult& result);
  /// finishMask(), then the mask is kept for the next frame's flow (previous_mask_).
  void finish(const cv::Mat& dynamic, const cv::Size& size, bool at_background, MaskResult& result);
  /// Clean-up, margin and upsampling of `dynamic` (at background resolution with depth_small_
  /// when `at_background`, else at input resolution).
  void finishMask(const cv::Mat& dynamic, const cv::Size& size, bool at_background, MaskResult& result);

  DynamicMaskOptions options_;
  FlowMotionMasker flow_;
  Timestamp prepared_stamp_ns_ = -1;  ///< frame prepareFlow() ran for
  double prepared_ms_ = 0.0;          ///< its time, counted in that frame's total_ms [ms]
  std::unique_ptr<SegmentScheduler> segment_;
  BackgroundModel background_;
  MaskCleaner full_cleaner_;
  MaskCleaner small_cleaner_;
  bool warned_ = false;
  /// The last frame used a network mask (its crowd aids off); true before the first frame, as a
  /// network that runs on every frame gives one from the first frame on.
  bool network_mask_in_use_ = true;
  int background_updates_ = 0;  ///< updates of B since construction / reset()
  int flow_frames_ = 0;  ///< frames with a flow since construction / reset() (the start: unknown_motion_is_dynamic)
  BoxDepthSettings box_settings_;
  DepthGrowSettings grow_settings_;
  cv::Mat seg_small_, flow_small_;
  cv::Mat depth_small_, raw_small_, rendered_small_, consistency_small_, combined_;
  cv::Mat nearest_layer_small_, farther_layers_small_,
      no_occluder_small_;        ///< depth-layer cut (DynamicMaskOptions::depth_layers)
  cv::Mat margin_kernel_small_;  ///< margin at background resolution (depth-aware margin only)
  cv::Mat margin_depth_, margin_grown_;
  cv::Mat seeds_small_;                                  ///< moving-point seeds at background resolution
  int halo_small_px_ = 6;                                ///< width of the flow's halo at background resolution [px]
  std::unique_ptr<ObjectPermanence> permanence_;         ///< null when permanence_frames is 0
  std::unique_ptr<ObjectPermanence> moving_permanence_;  ///< null when moving_permanence_frames is 0
  cv::Mat evidence_small_, kept_small_;    ///< this frame's own findings; regions kept from the last frame
  cv::Mat cleaned_small_;                  ///< final dynamic pixels at background resolution, before the margin
  cv::Mat carried_small_, relearn_small_;  ///< previous mask along the flow; B's warp errors taken out
  cv::Mat previous_mask_;                  ///< final mask of the previous frame (input size), see FlowMotionMasker
};

}  // namespace mask
}  // namespace dypho
