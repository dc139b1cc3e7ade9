#pragma once
/// \file mask_stage.h
/// The mask module's stage: DynamicMasker plus the policy around it, shared by the in-process
/// pipeline and DynamicMaskNodelet (which only converts and publishes).
///
/// Policy, in one place:
///  - Ego-motion prior T_prev_cur: from the shared constant-velocity model (motion_prior.h) fed
///    with the tracked poses; it is the motion between the previous *masked* frame and this one
///    (poses predicted at both stamps when tracking has not caught up), and absent across a jump
///    (relocalisation, loop closure, reset) or a gap.
///  - R_d: depth rendered from the Gaussian map at the predicted pose of a frame, offered with the
///    frame's stamp; used only by the frame with that stamp (within rendered_depth_tolerance_s),
///    never by a later one whose pose it does not show.
///  - Moving points (tracking -> mask): the newest set seen at most moving_points_max_age_s before
///    a frame is carried into that frame's camera with the motion model (as is, without poses)
///    and grown into the mask (DynamicMaskOptions::moving_point_seeds).
///  - Stamps (stamp_gate.h, the same rule as tracking): a repeated stamp, or one at most 1 s
///    before the newest (a late frame), is dropped (MaskResult::dropped, no mask); a jump back by
///    more (a looped bag) restarts the masker: the flow, the background model B_i and the motion
///    prior are forgotten.
///  - Live (previous_pose_wait_s): a frame's mask waits briefly for the previous frame's tracked
///    pose, so that its prior is fresh; not when frames wait behind it.
/// Thread-safe: poses and R_d may arrive on other threads than process(). A caller hands moving
/// points on before the pose they belong to (the pose wakes a waiting process()).

#include <cstddef>
#include <condition_variable>
#include <mutex>
#include <optional>

#include <opencv2/core.hpp>

#include "dypho/common/camera.h"
#include "dypho/common/motion_prior.h"
#include "dypho/common/stamp_gate.h"
#include "dypho/common/types.h"
#include "dypho/mask/dynamic_masker.h"

namespace dypho::mask {

/// Settings of the stage's policy (not of the mask algorithm).
struct MaskStageOptions {
  /// R_d offered for stamp t is used by the frame whose stamp is within this of t [s]; default
  /// 0.005 (a sixth of a 30 Hz frame interval: only that frame's own render qualifies).
  double rendered_depth_tolerance_s = 0.005;
  /// Poses further apart than this give no velocity (motion_prior.h) [s]; default 1.0.
  double motion_max_gap_s = 1.0;
  /// Moving points seen at most this long before a frame are grown into its mask [s]; default
  /// 0.1 (three 30 Hz frames: tracking may run a frame or two behind the mask).
  double moving_points_max_age_s = 0.1;
  /// Live: after its dense flow, a frame's mask waits at most this long for the tracked pose of
  /// the frame masked before it, unless frames wait behind it (the graph is behind) [s]; default
  /// 0.033 (one frame at 30 Hz), range [0, 1]; 0 = never waits. With that pose the ego-motion
  /// prior is fresh (one frame interval from a tracked pose) instead of predicted from older
  /// poses, which on fast turns put the background's depth edges off and masked the static
  /// scene; the price is pose latency (docs/journal/benchmarks-2026.md section 39). Offline
  /// callers hand the pose on before the next frame: no wait.
  double previous_pose_wait_s = 0.033;
};

/// Counters since construction or reset() (the graph test and diagnostics read them).
struct MaskStageStats {
  std::size_t frames = 0;                      ///< frames masked
  std::size_t frames_with_ego_motion = 0;      ///< frames given a T_prev_cur from tracked poses
  std::size_t frames_with_rendered_depth = 0;  ///< frames whose B_i update used R_d
  std::size_t rendered_depth_offered = 0;      ///< R_d images received
  std::size_t rendered_depth_unmatched = 0;    ///< R_d images no frame used (stamp did not match)
  std::size_t degraded_frames = 0;             ///< MaskResult::degraded
  std::size_t restarts = 0;                    ///< restarts after a stamp jumped back
  std::size_t dropped_out_of_order = 0;        ///< frames dropped for a repeated or late stamp
  std::size_t frames_caught_up = 0;            ///< frames masked in catch-up mode (MaskPrior::catching_up)
  std::size_t frames_with_fresh_prior =
      0;  ///< of frames_with_ego_motion, those with a fresh one (MaskPrior::prediction_fresh)
  std::size_t pose_waits_timed_out = 0;  ///< frames that waited previous_pose_wait_s in vain
  /// of frames_with_ego_motion, stale ones whose newest pose was one frame before the previous
  /// frame's (MaskPrior::pose_frames_behind 1)
  std::size_t frames_with_prior_one_behind = 0;
  std::size_t network_runs = 0;              ///< network runs started (MaskResult::network_started)
  std::size_t network_results_late = 0;      ///< async results too old on arrival (MaskResult::network_result_late)
  std::size_t frames_with_network_mask = 0;  ///< frames judged with a network mask (raw_segment_mask)
};

class MaskStage {
 public:
  /// Validates the options (std::invalid_argument); loads the network when configured.
  explicit MaskStage(const DynamicMaskOptions& options, const MaskStageOptions& stage = {});

  /// The tracked pose of a frame (tracking -> mask).
  void observePose(const PoseUpdate& update);
  /// Points tracking saw move on a frame (tracking -> mask), for the next frames' masks.
  void observeMovingPoints(MovingPoints points);
  /// R_d for the frame stamped `stamp_ns`: CV_32FC1 [m], at workingCamera() or the input size.
  void setPredictedDepth(Timestamp stamp_ns, cv::Mat depth_m);
  /// True when R_d can enter the mask: the background model is on and its weight tau > 0. The
  /// pipeline renders R_d, and the nodelet subscribes to it, only then.
  bool wantsRenderedDepth() const;
  /// Camera at which the background model works: render R_d through this.
  CameraIntrinsics workingCamera(const CameraIntrinsics& input) const;

  /// The mask of `frame` (DynamicMasker::compute with the prior described above).
  /// `frames_waiting`: frames a live caller holds behind this one; from
  /// DynamicMaskOptions::catch_up_frames_waiting on, the frame is masked in catch-up mode
  /// (MaskPrior::catching_up). Offline callers pass 0.
  MaskResult process(const RgbdFrame& frame, std::size_t frames_waiting = 0);

  /// Forgets the masker's history, the motion prior and any waiting R_d.
  void reset();
  MaskStageStats stats() const;
  const DynamicMasker& masker() const { return masker_; }

 private:
  /// Pose at `stamp_ns` from the motion model (the last pose itself or a prediction).
  std::optional<Eigen::Isometry3d> poseAt(Timestamp stamp_ns) const;
  /// Waits (at most previous_pose_wait_s, `lock` released meanwhile) until the pose of the frame
  /// masked before arrived; false when it did not.
  bool waitForPreviousPose(std::unique_lock<std::mutex>& lock);
  /// The frame's ego-motion prior, R_d and moving points (prior_mutex_ held); the frame becomes
  /// the previous one.
  void fillPrior(const RgbdFrame& frame, MaskPrior* prior);

  MaskStageOptions stage_options_;
  std::mutex process_mutex_;  ///< one process() at a time (the masker is not thread-safe)
  DynamicMasker masker_;

  mutable std::mutex prior_mutex_;  ///< guards everything below
  ConstantVelocityModel motion_;
  std::optional<Timestamp> previous_frame_ns_;
  StampGate stamp_gate_;
  cv::Mat rendered_depth_m_;
  Timestamp rendered_stamp_ns_ = 0;
  MovingPoints moving_points_;
  MaskStageStats stats_;
  std::condition_variable pose_arrived_;     ///< signalled by observePose
  std::optional<Timestamp> newest_pose_ns_;  ///< newest stamp observePose was given
};

}  // namespace dypho::mask
