#include "dypho/mask/dynamic_masker.h"

#include <chrono>
#include <cmath>
#include <exception>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/mask/box_depth_segmenter.h"
#include "dypho/mask/object_permanence.h"
#include "dypho/mask/segment_scheduler.h"
#include "mask_internal.h"

namespace dypho {
namespace mask {

using internal::Clock;
using internal::msSince;

namespace {

/// Appends `note` to `result.message`, after a "; " when it holds one already.
void addNote(MaskResult& result, const std::string& note) {
  result.message += (result.message.empty() ? "" : "; ") + note;
}

MaskCleanerSettings cleanerAt(const DynamicMaskOptions& o, double scale) {
  MaskCleanerSettings s;
  s.open_radius_px = 1;  // speckles of the consistency test, one pixel at this resolution
  s.min_region_area_px = static_cast<int>(std::lround(o.min_region_area_px * scale * scale));
  s.dilate_radius_px = o.margin_px > 0 ? std::max(1, static_cast<int>(std::lround(o.margin_px * scale))) : 0;
  return s;
}

/// The background-resolution cleaner: without the margin when finish() grows it depth-aware.
MaskCleanerSettings smallCleaner(const DynamicMaskOptions& o) {
  MaskCleanerSettings s = cleanerAt(o, o.background.scale);
  if (o.margin_depth_aware) s.dilate_radius_px = 0;
  return s;
}

/// Intrinsics of the background model: the resized image, treated as pinhole.
CameraIntrinsics scaled(const CameraIntrinsics& c, const cv::Size& small, double scale) {
  CameraIntrinsics s = resizedIntrinsics(c, small, scale);
  s.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
  return s;
}

}  // namespace

DynamicMasker::DynamicMasker(const DynamicMaskOptions& options)
    : options_((options.validate(), options)),
      flow_(options.flow),
      segment_(std::make_unique<SegmentScheduler>(options.yolo)),
      background_(options.background),
      full_cleaner_(cleanerAt(options, 1.0)),
      small_cleaner_(smallCleaner(options)) {
  box_settings_.depth_range_m = options.yolo.box_depth_range_m;
  grow_settings_.depth_range_m = options.yolo.box_depth_range_m;
  grow_settings_.sigma_m = options.background.sigma_m;
  grow_settings_.min_seed_area_px = cleanerAt(options, options.background.scale).min_region_area_px;
  grow_settings_.max_growth_ratio = options.background.grow_max_ratio;
  // The flow's halo on the background: its margin plus about 4 px of flow smoothing (full res).
  halo_small_px_ = std::max(1, static_cast<int>(std::lround((options.flow.dilate_px + 4) * options.background.scale)));
  const auto makePermanence = [&](int max_quiet_frames) {
    PermanenceSettings p;
    p.max_quiet_frames = max_quiet_frames;
    p.sigma_m = options.background.sigma_m;
    return std::make_unique<ObjectPermanence>(p);
  };
  if (options.permanence_frames > 0) permanence_ = makePermanence(options.permanence_frames);
  if (options.moving_permanence_frames > 0) moving_permanence_ = makePermanence(options.moving_permanence_frames);
  const int margin_small = cleanerAt(options, options.background.scale).dilate_radius_px;
  if (options.margin_depth_aware && margin_small > 0) {
    margin_kernel_small_ =
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * margin_small + 1, 2 * margin_small + 1));
  }
}

DynamicMasker::~DynamicMasker() = default;

void DynamicMasker::reset() {
  background_updates_ = 0;
  flow_frames_ = 0;
  previous_mask_.release();
  network_mask_in_use_ = true;
  resetPermanence();
  flow_.reset();
  segment_->reset();
  background_.reset();
}

const std::string& DynamicMasker::segmentStatus() const { return segment_->status(); }
bool DynamicMasker::segmentReady() const { return segment_->ready(); }

cv::Size DynamicMasker::workingSize(const cv::Size& input) const {
  return scaledImageSize(input.width, input.height, options_.background.scale);
}

/// One frame as compute() hands it from step to step.
struct DynamicMasker::FrameState {
  FrameState(const RgbdFrame& frame_in, const MaskPrior& prior_in) : frame(frame_in), prior(prior_in) {}
  const RgbdFrame& frame;
  const MaskPrior& prior;
  cv::Size size;                  ///< input size
  cv::Size small;                 ///< background resolution (workingSize())
  bool have_depth = false;        ///< depth CV_32FC1 of the colour size and a valid camera
  bool run_background = false;    ///< background model on, with usable depth
  bool network = false;           ///< a network mask was in use on the last frame (crowd aids off)
  bool rendered_ignored = false;  ///< R_d was given at an unusable type or size
  double test_ms = 0.0;           ///< the consistency test's wall time [ms]
  FlowMaskResult flow;            ///< this frame's motion mask
  /// The relative pose B is warped with: the flow's fitted one (FlowMaskOptions::fit_rigid_motion,
  /// BackgroundOptions::warp_with_flow_fit) when it has one, else the prior's.
  std::optional<Eigen::Isometry3d> T_prev_cur;
  SegmentStep seg;                    ///< this frame's segment mask
  bool background_restarted = false;  ///< B started again at this frame (motion since B unknown)
};

void DynamicMasker::prepareFlow(const RgbdFrame& frame, bool catching_up) {
  const auto t0 = Clock::now();
  flow_.setCatchingUp(catching_up);
  flow_.prepareFlow(frame);
  prepared_stamp_ns_ = frame.stamp_ns;
  prepared_ms_ = msSince(t0);
}

MaskResult DynamicMasker::compute(const RgbdFrame& frame, const MaskPrior& prior) {
  // The flow prepared for this frame counts in its time.
  const auto t0 = Clock::now() - std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(
                                     prepared_stamp_ns_ == frame.stamp_ns ? prepared_ms_ : 0.0));
  prepared_stamp_ns_ = -1;
  MaskResult result;
  FrameState f(frame, prior);
  f.size = frame.bgr.size();
  f.have_depth = !frame.depth_m.empty() && frame.depth_m.size() == f.size && frame.depth_m.type() == CV_32FC1 &&
                 frame.camera.valid();
  f.run_background = options_.background.enabled && f.have_depth;
  f.small = workingSize(f.size);
  flow_.setCatchingUp(prior.catching_up);

  // 1. Motion mask: flow and ego-motion (beside the background's consistency test).
  computeMotionAndConsistency(f);
  if (!reportMotion(f, result)) {  // unusable input: nothing else can run
    result.total_ms = msSince(t0);
    return result;
  }
  // 2. Segment mask (network every N-th frame / async, carried by the flow in between).
  computeSegment(f, result);
  if (startsAllDynamic(f, result)) {
    result.total_ms = msSince(t0);
    return result;
  }
  // 3. Raw mask, background model, consistency, fused at background resolution (without the
  // background model: flow OR segment mask at input size).
  const auto t_bg = Clock::now();
  if (f.run_background) {
    fuseAtBackground(f, result);
  } else {
    fuseAtInput(f, result);
  }
  result.background_ms = f.test_ms + msSince(t_bg);
  result.total_ms = msSince(t0);
  return result;
}

void DynamicMasker::computeMotionAndConsistency(FrameState& f) {
  // The crowd aids of the flow mask (residual memory, depth layers) serve the flow-only mask; a
  // running network segments people whatever their speed and depth, and with it they only cost
  // accuracy (Bonn crowd with YOLOX-nano: 1.45 cm without, 1.7-2.7 cm with them). A network
  // whose newest mask was too old to use (YoloOptions::max_age_frames) leaves them on.
  f.network = segment_->ready() && network_mask_in_use_;
  flow_.setResidualMemoryEnabled(!f.network);
  f.T_prev_cur = f.prior.T_prev_cur;
  // No prediction once the background model is established: tracking was lost (its motion model
  // starts again). (The first frames have none either; their B is still being built.)
  const bool no_prediction =
      !f.prior.T_prev_cur && f.run_background && background_updates_ >= options_.background.veto_after_updates;
  // A stale prediction without a gap, its newest pose at most
  // FlowMaskOptions::stale_prediction_kept_frames_behind frames before the previous frame, takes
  // the fresh one's way: the flow's ego-motion keeps it, only B is warped with the fit.
  const bool stale = f.prior.T_prev_cur && !f.prior.prediction_fresh;
  const bool fit_for_background = options_.background.warp_with_flow_fit && f.run_background;
  const int kept_behind = options_.flow.stale_prediction_kept_frames_behind;
  const bool stale_as_fresh = stale && !f.prior.after_gap && options_.flow.fit_rigid_motion && kept_behind > 0 &&
                              f.prior.pose_frames_behind >= 0 && f.prior.pose_frames_behind <= kept_behind &&
                              fit_for_background;
  if (options_.flow.fit_rigid_motion && (no_prediction || (stale && !stale_as_fresh))) {
    motionFittedFromAGuess(f, no_prediction);
  } else if (fit_for_background && f.prior.T_prev_cur && (f.prior.prediction_fresh || stale_as_fresh)) {
    motionThenConsistencyWithTheFit(f);
  } else {
    motionBesideConsistency(f);
  }
}

void DynamicMasker::motionFittedFromAGuess(FrameState& f, bool no_prediction) {
  // The background is warped with the motion fitted to the flow, so the test waits for it: a
  // prediction made from older poses (a live graph's mask runs before tracking has posed the
  // previous frame) or none at all (the first frames, after a loss) puts B's depth edges off
  // and the static view in front of them fails the test. Without a prediction the fit starts
  // from a still camera; an unwarped B behind a turning camera would mark the whole static
  // view dynamic, tracking would find no features in it, stay lost and give no prediction
  // (docs/journal/benchmarks-2026.md section 29).
  const Eigen::Isometry3d start = f.prior.T_prev_cur.value_or(Eigen::Isometry3d::Identity());
  f.flow = flow_.compute(f.frame, start, previous_mask_, PoseFitUse::kEgoMotion);
  if (f.flow.T_prev_cur) f.T_prev_cur = f.flow.T_prev_cur;
  if (!f.run_background) return;
  testAgainstBackground(f);
  // The camera's motion since B is unknown (lost, or frames missing) and the flow did not find
  // it: B was carried with a guess. When the guess put B off the view (far more of it fails the
  // test than the last mask held), B starts again here: a static region masked once is not
  // learnt, and the view stayed dynamic for twenty frames (docs/journal/benchmarks-2026.md
  // section 30). A guess that fits keeps B: in a crowd, a new B would learn the people.
  const bool guessed = (no_prediction || f.prior.after_gap) && !f.flow.ego_motion_from_pose;
  if (guessed && background_updates_ > 0 && backgroundLostTheView()) {
    background_.reset();
    background_updates_ = 0;
    f.background_restarted = true;
    testAgainstBackground(f);  // against the new, empty B: nothing fails it
  }
}

void DynamicMasker::motionThenConsistencyWithTheFit(FrameState& f) {
  // A fresh prediction: the flow's ego-motion starts from it (its homography absorbs a rotation
  // error); B, which has no such absorber, is warped with the motion fitted to the flow from it
  // (BackgroundOptions::warp_with_flow_fit), so the test waits for the flow.
  f.flow = flow_.compute(f.frame, f.prior.T_prev_cur, previous_mask_, PoseFitUse::kReport);
  if (f.flow.T_prev_cur_fitted) f.T_prev_cur = f.flow.T_prev_cur_fitted;
  testAgainstBackground(f);
}

void DynamicMasker::motionBesideConsistency(FrameState& f) {
  // The flow masker checks the colour image, depth size and camera size. Exceptions of either
  // task are rethrown here, after both finished.
  std::exception_ptr failure[2];
  cv::parallel_for_(
      cv::Range(0, 2),
      [&](const cv::Range& range) {
        for (int task = range.start; task < range.end; ++task) {
          try {
            if (task == 0) {
              f.flow = flow_.compute(f.frame, f.prior.T_prev_cur, previous_mask_);
            } else if (f.run_background) {
              testAgainstBackground(f);
            }
          } catch (...) {
            failure[task] = std::current_exception();
          }
        }
      },
      2.0);
  for (const std::exception_ptr& e : failure) {
    if (e) std::rethrow_exception(e);
  }
}

void DynamicMasker::testAgainstBackground(FrameState& f) {
  // The consistency test of D_i against the prior (warped B_{i-1}, rendered depth) needs no flow:
  // it runs beside the flow on a second thread of OpenCV's pool (serially with one thread).
  const auto t = Clock::now();
  const cv::Mat& rendered = f.prior.rendered_depth_m;
  cv::resize(f.frame.depth_m, depth_small_, f.small, 0, 0, cv::INTER_NEAREST);
  rendered_small_.release();
  if (!rendered.empty()) {
    if (rendered.type() == CV_32FC1 && rendered.size() == f.small) {
      rendered_small_ = rendered;  // rendered at the working resolution already
    } else if (rendered.type() == CV_32FC1 && rendered.size() == f.size) {
      cv::resize(rendered, rendered_small_, f.small, 0, 0, cv::INTER_NEAREST);
    } else {
      f.rendered_ignored = true;
    }
  }
  background_.test(depth_small_, rendered_small_, scaled(f.frame.camera, f.small, options_.background.scale),
                   f.T_prev_cur, consistency_small_);
  f.test_ms = msSince(t);
}

bool DynamicMasker::backgroundLostTheView() const {
  const double previous =
      previous_mask_.empty() ? 0.0 : static_cast<double>(cv::countNonZero(previous_mask_)) / previous_mask_.total();
  const double failed = static_cast<double>(cv::countNonZero(consistency_small_)) / consistency_small_.total();
  return failed > previous + kLostViewShare;
}

bool DynamicMasker::reportMotion(const FrameState& f, MaskResult& result) {
  const FlowMaskResult& flow = f.flow;
  if (f.rendered_ignored)
    addNote(result, "rendered depth ignored: must be CV_32FC1 of the colour size or of workingSize()");
  if (f.background_restarted)
    addNote(result, "background model restarted: the camera's motion since the last frame was not found");
  result.rendered_depth_used = f.run_background && !rendered_small_.empty();
  result.flow_ms = flow.total_ms;
  result.ego_motion_from_pose = flow.ego_motion_from_pose;
  result.raw_flow_mask = flow.raw_flow_mask;
  if (flow.degraded) {
    result.degraded = true;
    addNote(result, flow.message);
  } else if (!flow.message.empty()) {
    addNote(result, flow.message);
  }
  if (flow.mask.empty()) {
    result.mask = flow.mask;
    return false;
  }
  return true;
}

void DynamicMasker::computeSegment(FrameState& f, MaskResult& result) {
  if (!warned_ && !segment_->ready()) {
    addNote(result, segment_->status());
    warned_ = true;
  }
  const auto t_seg = Clock::now();
  f.seg = segment_->step(f.frame, flow_.lastFlow());
  const SegmentStep& seg = f.seg;
  // Decides the crowd aids of the next frame's flow (this frame's flow already ran): on while no
  // network mask is in use (none yet, or the newest was too old: YoloOptions::max_age_frames).
  network_mask_in_use_ = !seg.mask.empty();
  if (seg.too_old)
    addNote(result, "segment: newest network mask older than " + std::to_string(options_.yolo.max_age_frames) +
                        " frames, not used");
  result.segment_ms = msSince(t_seg);
  result.segment_fresh = seg.fresh;
  result.segment_age_frames = seg.age_frames;
  result.network_started = seg.network_started;
  result.network_result_late = seg.late_result;
  result.detection_boxes = seg.boxes_image;
  result.raw_segment_mask = seg.mask;
  if (!seg.message.empty()) addNote(result, "segment: " + seg.message);
}

bool DynamicMasker::startsAllDynamic(const FrameState& f, MaskResult& result) {
  // Safe start: with no flow and no fresh network mask nothing has judged this frame's pixels;
  // people in it would look static (tracking verifies a first keyframe built from such a frame).
  // With unjudged_is_dynamic the frame is all dynamic and the background model does not learn it.
  result.unjudged = flow_.lastFlow().empty() && !f.seg.fresh;
  if (options_.unjudged_is_dynamic && result.unjudged) {
    allDynamic(f.size, "nothing judged yet (no flow, no network mask)", result);
    return true;
  }

  // Start in a crowd: on the first frames with a flow (as many as the background model needs to
  // be established, background_veto_after_updates), a frame whose camera motion the flow did not
  // find and that carries no earlier mask says nothing about what is static; people who fill the
  // view would carry its pose (a still camera walked away with them). It is all dynamic, and the
  // background model does not learn it. Counted in flow frames, so that the start also ends
  // without depth or with the background model off.
  if (!flow_.lastFlow().empty()) ++flow_frames_;
  if (options_.unknown_motion_is_dynamic && f.flow.motion_unknown && f.seg.mask.empty() &&
      flow_frames_ <= options_.background.veto_after_updates) {
    allDynamic(f.size, "camera motion not found and no earlier mask to carry", result);
    return true;
  }
  return false;
}

void DynamicMasker::fuseAtBackground(const FrameState& f, MaskResult& result) {
  // The consistency test ran beside the flow; now that the flow measured the static scene's image
  // motion, a depth edge of B may be that share of it off (BackgroundOptions::motion_tolerance).
  background_.retest(depth_small_, f.flow.static_median_flow_px * options_.background.scale, consistency_small_);
  cutRawMaskAtBackground(f);
  if (background_updates_ == 0 && f.flow.raw_flow_mask.empty() && f.seg.mask.empty()) {
    // No raw mask yet (first frame): B_1 must not absorb the moving objects; wait a frame (the
    // consistency test above changed nothing that the next frame reads).
    finish(raw_small_, f.size, true, result);
    return;
  }
  cv::resize(consistency_small_, result.consistency_mask, f.size, 0, 0, cv::INTER_NEAREST);
  const bool still = vetoFlowOnBackground(f);
  const bool warp_error = dropBackgroundWarpError(f);
  if (warp_error) addNote(result, "background carried with a wrong motion: its unsupported failures relearnt");
  cv::bitwise_or(consistency_small_, raw_small_, combined_);
  if (options_.moving_point_seeds && !f.prior.moving_points_camera_m.empty()) {
    addMovingPointSeeds(f.prior.moving_points_camera_m, scaled(f.frame.camera, f.small, options_.background.scale));
  }
  ObjectPermanence* const permanence = activePermanence(f, still);
  if (permanence) {
    // What this frame found itself (the evidence that restarts a surface's quiet count), then
    // the surfaces of the previous frame that are still there.
    combined_.copyTo(evidence_small_);
    permanence->carry(flow_.lastFlow(), depth_small_, background_.prior(), kept_small_, evidence_small_);
    combined_ |= kept_small_;
  }
  if (options_.background.grow_in_depth) {
    // The growth limit holds while the view moves fast (median flow of 6 px per frame or more),
    // when the ego-motion model's errors on depth edges make flow regions on static surfaces.
    DepthGrowSettings grow = grow_settings_;
    if (f.flow.still_camera_weight > 0.0) grow.max_growth_ratio = 0.0;
    growRegionsInDepth(depth_small_, background_.prior(), grow, combined_);
  }
  // B_i learns D_i only where nothing (raw, consistency, grown) calls the pixel dynamic.
  background_.update(depth_small_, rendered_small_, combined_);
  if (warp_error) {
    relearn_small_.setTo(0, combined_);  // what the raw mask grew over stays unlearnt
    background_.relearn(depth_small_, relearn_small_);
  }
  ++background_updates_;
  finish(combined_, f.size, true, result);
  // The other mode's memory (or both, with none in use) starts afresh.
  if (permanence_ && permanence != permanence_.get()) permanence_->reset();
  if (moving_permanence_ && permanence != moving_permanence_.get()) moving_permanence_->reset();
  if (permanence) permanence->remember(cleaned_small_, evidence_small_, depth_small_);
}

bool DynamicMasker::dropBackgroundWarpError(const FrameState& f) {
  // Share of a failing region the raw mask must cover for it to stay: a person the flow or the
  // network found is largely inside their mask, while the flow's errors on a fast turn touch a
  // desk-wide failure along a strip (live on TUM fr1/rpy: 10-19 % of it).
  constexpr double kMinSupportShare = 0.25;
  const double min_share = options_.background.warp_error_min_share;
  if (min_share <= 0.0) return false;
  const cv::Mat& carried = flow_.carriedPrevious();
  carried_small_.create(f.small, CV_8UC1);
  carried_small_.setTo(0);
  if (!carried.empty()) cv::resize(carried, carried_small_, f.small, 0, 0, cv::INTER_NEAREST);
  // New failures: in neither the raw mask nor the previous frame's (relearn_small_ as scratch).
  cv::bitwise_or(raw_small_, carried_small_, relearn_small_);
  cv::bitwise_not(relearn_small_, relearn_small_);
  cv::bitwise_and(relearn_small_, consistency_small_, relearn_small_);
  const double new_share = static_cast<double>(cv::countNonZero(relearn_small_)) / relearn_small_.total();
  if (new_share <= min_share) return false;
  // A degraded flow's mask is the previous mask carried along, no evidence of this frame's: the
  // network's mask alone (seg_small_, cutRawMaskAtBackground) supports a region then.
  const cv::Mat none;
  const cv::Mat& support = !f.flow.degraded ? raw_small_ : f.seg.mask.empty() ? none : seg_small_;
  dropUnsupportedRegions(support, kMinSupportShare, consistency_small_, relearn_small_);
  return true;
}

ObjectPermanence* DynamicMasker::activePermanence(const FrameState& f, bool still) const {
  // Object permanence serves the flow-only mask (a network segments people whatever they do) and
  // starts once the background model is established: before, the depth growth has no background
  // to stop it and can spill over a wall nobody has seen yet, which must not last. A still camera
  // has its own (permanence_frames); a camera that moves slowly, under 6 px of image motion per
  // frame (still_camera_weight > 0), the other (moving_permanence_frames). Faster, the ego-motion
  // model's errors would be kept as well.
  if (f.network || background_updates_ < options_.background.veto_after_updates) return nullptr;
  if (still) return permanence_.get();
  return f.flow.still_camera_weight > 0.0 ? moving_permanence_.get() : nullptr;
}

void DynamicMasker::resetPermanence() {
  if (permanence_) permanence_->reset();
  if (moving_permanence_) moving_permanence_->reset();
}

void DynamicMasker::cutRawMaskAtBackground(const FrameState& f) {
  // Raw flow regions are cut to the depth of the people in them (no halo on the wall behind;
  // people behind people in a crowd); the segment mask is already depth-cut (boxes) or
  // pixel-exact (seg models).
  cv::resize(f.flow.mask, raw_small_, f.small, 0, 0, cv::INTER_NEAREST);
  // Depth layers behind the nearest one only while the camera is still enough for the flow's
  // regions to be people rather than the ego-motion model's errors at depth edges.
  const bool layers = options_.depth_layers > 1 && f.flow.still_camera_weight > 0.0 && !f.network;
  cutRegionsToDepthLayers(depth_small_, box_settings_, halo_small_px_, layers ? options_.depth_layers : 1, raw_small_,
                          layers ? &nearest_layer_small_ : nullptr);
  if (layers && background_updates_ >= options_.background.veto_after_updates) {
    // Layers behind the nearest one that the established background explains (the floor at a
    // person's feet, furniture in the flow's margin) are static: only the nearest layer is kept there.
    cv::subtract(raw_small_, nearest_layer_small_, farther_layers_small_);  // 0/255 masks: raw and not nearest
    no_occluder_small_.create(f.small, CV_8UC1);
    no_occluder_small_.setTo(0);
    vetoRegionsOnBackground(background_.prior(), depth_small_, no_occluder_small_, options_.background.sigma_m, 0.5,
                            0.5, farther_layers_small_);
    cv::bitwise_or(nearest_layer_small_, farther_layers_small_, raw_small_);
  }
  if (!f.seg.mask.empty()) {
    cv::resize(f.seg.mask, seg_small_, f.small, 0, 0, cv::INTER_NEAREST);
    raw_small_ |= seg_small_;
  }
}

bool DynamicMasker::vetoFlowOnBackground(const FrameState& f) {
  // Flow regions that the established background explains (same depth, no occluder in front)
  // are flow noise on the static scene; segment-mask pixels are never vetoed. Only while the
  // camera moves: the veto is for the ego-motion model's errors, which grow with the camera's
  // motion. With a still camera (cameraStill()) a flow region is motion, and the background
  // that "explains" it has learnt a person who stood still or stood there from the start.
  cv::resize(f.flow.mask, flow_small_, f.small, 0, 0, cv::INTER_NEAREST);
  flow_small_ &= raw_small_;
  const bool still = cameraStill(f.flow, f.prior.T_prev_cur);
  if (background_updates_ >= options_.background.veto_after_updates && (!still || options_.veto_flow_while_still)) {
    vetoRegionsOnBackground(background_.prior(), depth_small_, consistency_small_, options_.background.sigma_m, 0.9,
                            0.5, flow_small_);
  }
  if (!f.seg.mask.empty()) {
    cv::bitwise_or(flow_small_, seg_small_, raw_small_);
  } else {
    flow_small_.copyTo(raw_small_);  // no aliasing: both buffers are reused next frame
  }
  return still;
}

void DynamicMasker::fuseAtInput(const FrameState& f, MaskResult& result) {
  resetPermanence();
  if (options_.background.enabled && !f.have_depth) addNote(result, "no usable depth/camera: background model skipped");
  combined_ = f.flow.mask.clone();
  if (!f.seg.mask.empty()) combined_ |= f.seg.mask;
  finish(combined_, f.size, false, result);
}

bool cameraStill(const FlowMaskResult& flow, const std::optional<Eigen::Isometry3d>& T_prev_cur) {
  // Still: the textured pixels' median flow is under kStillFlowPx per frame, and either at least
  // kMinQuietShare of them do not move at all (FlowMaskResult::quiet_flow_share) or the
  // predicted pose moves less than kStillTranslationM. The median alone is not enough: a camera
  // circling the scene while it looks at its centre has a median of 1-2 px and parallax all the
  // same (11-15 mm per frame; 0-25 % of its pixels quiet). The pose alone is not enough either:
  // people the mask misses drag the tracked pose, and so the prediction, by up to a centimetre
  // per frame, while the wall behind them still does not move (31-93 % quiet in the synthetic
  // crowds before a still camera).
  constexpr double kStillFlowPx = 2.0;  // full-res px per frame
  constexpr double kMinQuietShare = 0.3;
  constexpr double kStillTranslationM = 0.005;  // per frame (15 cm/s at 30 Hz)
  if (flow.raw_flow_mask.empty() || !(flow.median_flow_px < kStillFlowPx)) return false;  // no flow, or moving
  return flow.quiet_flow_share >= kMinQuietShare ||
         (T_prev_cur && T_prev_cur->translation().norm() < kStillTranslationM);
}

void DynamicMasker::addMovingPointSeeds(const std::vector<cv::Point3f>& p_camera_m,
                                        const CameraIntrinsics& camera_small) {
  constexpr float kMaxDepthChangeM = 0.25f;         // a person moves a few cm per frame; more is another surface
  constexpr int kSeedRadiusPx = 2;                  // at background resolution
  const cv::Mat& background = background_.prior();  // the test of this frame made it, at this size
  const float sigma = static_cast<float>(options_.background.sigma_m);
  seeds_small_.create(combined_.size(), CV_8UC1);
  seeds_small_.setTo(0);
  int seeds = 0;
  for (const cv::Point3f& p : p_camera_m) {
    if (!(p.z > 0.f)) continue;
    const int u = static_cast<int>(std::lround(camera_small.fx * p.x / p.z + camera_small.cx));
    const int v = static_cast<int>(std::lround(camera_small.fy * p.y / p.z + camera_small.cy));
    if (u < 0 || v < 0 || u >= combined_.cols || v >= combined_.rows || combined_.at<uchar>(v, u) != 0) continue;
    const float d = depth_small_.at<float>(v, u);
    if (!(d > 0.f) || std::abs(d - p.z) > kMaxDepthChangeM) continue;  // no depth, or not the same surface
    const float b = background.at<float>(v, u);
    if (b > 0.f && d >= b - sigma) continue;  // the background explains it: static after all
    cv::circle(seeds_small_, cv::Point(u, v), kSeedRadiusPx, cv::Scalar(255), cv::FILLED);
    ++seeds;
  }
  if (seeds == 0) return;
  DepthGrowSettings grow = grow_settings_;
  grow.min_seed_area_px = 1;    // a seed is one point; the depth cluster and the background bound it
  grow.max_growth_ratio = 0.0;  // and it grows over the whole surface it moved with
  growRegionsInDepth(depth_small_, background, grow, seeds_small_);
  combined_ |= seeds_small_;
}

void DynamicMasker::allDynamic(const cv::Size& size, const std::string& why, MaskResult& result) {
  result.mask = cv::Mat(size, CV_8UC1, cv::Scalar(255));
  result.masked_fraction = 1.0;
  result.message += (result.message.empty() ? "" : "; ") + why + ": every pixel dynamic on this frame";
  previous_mask_.release();  // nothing to carry into the next frame
  resetPermanence();
}

void DynamicMasker::finish(const cv::Mat& dynamic, const cv::Size& size, bool at_background, MaskResult& result) {
  finishMask(dynamic, size, at_background, result);
  previous_mask_ = result.mask;  // carried into the next frame by the flow masker
}

void DynamicMasker::finishMask(const cv::Mat& dynamic, const cv::Size& size, bool at_background, MaskResult& result) {
  cv::Mat m = dynamic.clone();
  const int kept = (at_background ? small_cleaner_ : full_cleaner_).apply(m);
  if (at_background) m.copyTo(cleaned_small_);
  if (at_background && kept > 0 && !margin_kernel_small_.empty() && depth_small_.size() == m.size()) {
    // Depth-aware margin: grow by the margin, then take back the grown pixels whose depth lies
    // more than sigma_m behind the farthest masked depth within the margin.
    margin_depth_.create(m.size(), CV_32FC1);
    margin_depth_.setTo(0.f);
    depth_small_.copyTo(margin_depth_, m);
    cv::dilate(margin_depth_, margin_depth_, margin_kernel_small_);
    cv::dilate(m, margin_grown_, margin_kernel_small_);
    const float sigma = static_cast<float>(options_.background.sigma_m);
    for (int y = 0; y < m.rows; ++y) {
      const uchar* inside = m.ptr<uchar>(y);
      const float* d = depth_small_.ptr<float>(y);
      const float* z_far = margin_depth_.ptr<float>(y);
      uchar* g = margin_grown_.ptr<uchar>(y);
      for (int x = 0; x < m.cols; ++x) {
        if (g[x] != 0 && inside[x] == 0 && d[x] > 0.f && z_far[x] > 0.f && d[x] > z_far[x] + sigma) g[x] = 0;
      }
    }
    std::swap(m, margin_grown_);
  }
  if (m.size() != size) {
    cv::resize(m, result.mask, size, 0, 0, cv::INTER_LINEAR);
    cv::threshold(result.mask, result.mask, 127, 255, cv::THRESH_BINARY);
  } else {
    result.mask = m;
  }
  result.masked_fraction = static_cast<double>(cv::countNonZero(result.mask)) / static_cast<double>(size.area());
}

}  // namespace mask
}  // namespace dypho
