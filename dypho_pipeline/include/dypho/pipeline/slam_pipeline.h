#pragma once
/// \file slam_pipeline.h
/// The in-process composition: the mask, tracking and mapping stages chained with direct calls,
/// in the order the ROS graph moves their inputs and outputs over topics. Used by
/// `dypho_run_dataset`, the benches and the tests; the nodelets wrap the same stages one each.
///
/// Per frame i:
///  1. R_d: the mapping stage renders the depth of the map at the constant-velocity prediction of
///     frame i's pose, at the mask's working resolution (MappingStage::predictedDepth; the map as
///     it stood after the job of the keyframe before the newest, so runs are repeatable), and
///     offers it to the mask stage for frame i (graph: mapping publishes it on
///     rendered/depth_predicted when it receives pose i-1).
///  2. The mask stage masks frame i (graph: mask nodelet, topic mask).
///  3. The tracking stage tracks frame i (graph: tracking nodelet, topics pose/tracking_status).
///  4. The pose goes to the mask and mapping stages' motion models (graph: tracking_status).
///  5. Corrections of earlier keyframes, then the new keyframe, go to mapping (graph: topics
///     keyframe_corrections, keyframe).
/// R_d is rendered only when MaskStage::wantsRenderedDepth() (background model on, tau > 0).
/// With TrackingOptions::localization_only nothing goes to mapping (step 5): no keyframes, no
/// corrections, no training, so the map loaded with a session (session_store.h) stays as it was.
/// A keyframe goes to mapping only at a trusted, anchored pose: a tracker lost or searching a
/// restored map, or in a segment not yet tied to the map, never seeds it.
///
/// process() is maskFrame() (steps 1-2) then trackFrame() (steps 3-5, handOnTracked() for 4-5). Threads: process() from
/// one thread; or, pipelined like the graph's mask and tracking nodelets, maskFrame() on one
/// thread and trackFrame() on another, so that frame k is tracked while frame k+1 is masked (the
/// stages' shared state is thread-safe: MaskStage's prior, MappingStage). Frame k+1's ego-motion
/// prior and R_d then predict from the newest pose tracking has handed on, at least frame k-1's
/// (the constant-velocity model extrapolates to both stamps; motion_prior.h).

#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mapping/mapping_stage.h"
#include "dypho/mask/mask_stage.h"
#include "dypho/pipeline/pipeline_options.h"
#include "dypho/tracking/tracking_stage.h"

namespace dypho::pipeline {

/// What happened to one frame.
struct FrameReport {
  tracking::TrackingResult tracking;  ///< pose, state, keyframe, tracking stage times
  double render_ms = 0.0;             ///< rendering R_d for this frame [ms] (0 when none)
  double mask_ms = 0.0;               ///< time of the mask stage [ms]
  double mapping_ms = 0.0;            ///< handing a keyframe / corrections to mapping [ms]
  double masked_fraction = 0.0;       ///< share of the image the mask excluded [0, 1]
  bool mask_degraded = false;         ///< the mask core could not trust its mask this frame
  bool rendered_depth_used = false;   ///< R_d entered the background model on this frame
  /// The frame's stamp was repeated or late (stamp_gate.h): not masked, not tracked, no pose;
  /// `message` says why. A jump back by more than 1 s restarts instead (tracking.restarted).
  bool dropped = false;
  std::string message;  ///< why the frame was dropped
};

/// A frame after the mask stage, on its way to tracking (maskFrame() -> trackFrame()).
struct MaskedFrame {
  RgbdFrame frame;  ///< the input frame (images shared, not copied)
  cv::Mat mask;     ///< CV_8UC1, 255 = dynamic; empty = all static
  /// Whether the mask judged this frame (the flow's first frame without a network did not; an
  /// external mask did; no mask: unsaid).
  tracking::MaskJudgement judgement = tracking::MaskJudgement::kUnknown;
  FrameReport report;  ///< render/mask fields filled; `dropped` when the mask stage rejected the stamp
};

class SlamPipeline {
 public:
  /// `mode`: kDeterministic for repeatable offline runs (see MappingStage).
  explicit SlamPipeline(const PipelineOptions& options,
                        mapping::MappingMode mode = mapping::MappingMode::kDeterministic);
  /// kDeterministic or kLive, as constructed.
  mapping::MappingMode mappingMode() const { return mapping_.mode(); }

  /// Processes one frame. `external_mask` (CV_8UC1, 255 = dynamic) is used only with
  /// MaskSource::kExternal; an empty one means "all static".
  FrameReport process(const RgbdFrame& frame, const cv::Mat& external_mask = cv::Mat());

  /// Steps 1-2 of process(): R_d for the frame, then its mask (or `external_mask`, see process()).
  /// A frame the mask stage drops (repeated or late stamp) comes back with report.dropped set.
  /// `frames_waiting`: frames a live caller holds behind this one (MaskStage::process; 0 offline).
  MaskedFrame maskFrame(const RgbdFrame& frame, const cv::Mat& external_mask = cv::Mat(),
                        std::size_t frames_waiting = 0);
  /// Steps 3-5 of process(): tracks a masked frame, hands its pose to the mask and mapping stages
  /// and its corrections and keyframe to mapping. A frame already dropped by the mask stage is
  /// returned as it is.
  FrameReport trackFrame(MaskedFrame masked);
  /// Steps 4-5 of process() alone, for a frame tracked by the caller (RealtimeRunner's live
  /// tracker runs the tracking stage itself): a frame the stage dropped comes back dropped;
  /// otherwise its pose goes to the mask and mapping stages, its corrections and keyframe to
  /// mapping. `report`: the frame's render/mask fields; returned with the tracking ones filled.
  FrameReport handOnTracked(tracking::TrackingOutput out, FrameReport report);

  /// End of the tracking, after the last frame and before the trajectories are saved and
  /// finish(): the tracking stage's finishRun (the final global BA with
  /// TrackingOptions::global_ba_at_end); the keyframes it moved go to mapping.
  tracking::RunEnd finishTracking();

  /// End of the sequence: the mapping stage finishes its queue and runs the final refinement.
  void finish() { mapping_.finish(); }

  /// With mapping's pose_refinement: finish(), then the map's refined keyframe poses become the
  /// tracker's (TrackingStage::adoptKeyframePoses), so a trajectory saved after it follows them.
  /// Returns the keyframes moved (0 without a map, with pose_refinement off or with
  /// TrackingOptions::localization_only).
  std::size_t adoptMapKeyframePoses();

  mask::MaskStage& mask() { return mask_; }
  tracking::TrackingStage& tracking() { return tracking_; }
  mapping::MappingStage& mapping() { return mapping_; }
  const PipelineOptions& options() const { return options_; }

 private:
  bool wantsRenderedDepth() const;
  /// Keyframes and corrections go to mapping: a map is built and tracking may change it (not
  /// TrackingOptions::localization_only, where the loaded map stays as it is).
  bool mapsFrames() const;
  /// Hands a pose held back by PipelineOptions::mask_poses_one_frame_late to the mask stage.
  void handLatePoseToMask();

  PipelineOptions options_;
  mask::MaskStage mask_;
  tracking::TrackingStage tracking_;
  mapping::MappingStage mapping_;
  /// The last tracked frame's pose and moving points, for the mask stage after the next mask
  /// (PipelineOptions::mask_poses_one_frame_late).
  struct LatePose {
    PoseUpdate pose;
    MovingPoints moving_points;
  };
  std::optional<LatePose> late_pose_;
};

}  // namespace dypho::pipeline
