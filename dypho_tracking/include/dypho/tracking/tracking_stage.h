#pragma once
/// \file tracking_stage.h
/// The tracking module's stage: RgbdOdometry plus the policy around it, shared by the in-process
/// pipeline and TrackingNodelet (which only converts and publishes).
///
/// Policy, in one place:
///  - Every frame from the first keyframe on is recorded (TrajectoryRecorder): the final
///    trajectory follows the later local-BA and loop corrections of each frame's keyframe; a lost
///    frame keeps the pose it was published with; frames before the first keyframe have none.
///  - Stamps (stamp_gate.h): a repeated stamp, or one at most 1 s before the newest (a late frame),
///    is dropped (TrackingOutput::dropped, not tracked, not recorded); a jump back by more (a
///    looped bag) resets the tracker and clears the recorded trajectory: a new world begins.
///  - The pose handed to the other stages (PoseUpdate) is trusted only when tracking is OK,
///    anchored only outside a re-initialised segment (TrackingResult::anchored), and
///    marked discontinuous where it jumps (first keyframe, relocalisation, re-initialisation, loop
///    closure), so no stage forms a velocity across a jump (motion_prior.h).
///  - Keyframe poses moved by local BA or loop closure leave as one batch per frame
///    (TrackingOutput::corrections), for mapping to re-anchor.
///  - After restoreSession the trajectory starts empty; frames before the camera is found in the
///    restored map (or a new segment starts) are not recorded. With localization_only a stamp
///    that jumps back restores the same session again (the loaded map is never dropped).
///  - map -> odom (TrackingOutput::T_map_odom, odom_frame.h) takes the pose's jumps, so that
///    odom -> camera stays smooth (REP-105).
/// Thread-safe: process(), session/restore, the trajectory queries and save run under one lock.

#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/motion_prior.h"
#include "dypho/common/stamp_gate.h"
#include "dypho/common/types.h"
#include "dypho/tracking/odom_frame.h"
#include "dypho/tracking/rgbd_odometry.h"
#include "dypho/tracking/trajectory_recorder.h"

namespace dypho::tracking {

/// What one frame gave.
struct TrackingOutput {
  TrackingResult result;  ///< the tracker's result (pose, state, keyframe, timings)
  PoseUpdate pose;        ///< for the mask and mapping stages
  const KeyframePoseCorrections& corrections() const { return result.corrected_keyframes; }
  bool restarted = false;  ///< the stamp jumped back: tracker and trajectory reset
  /// REP-105 map -> odom for a trusted, anchored pose (odom_frame.h); identity otherwise.
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();
  /// What became of a session at this frame, for the log: restored (restoreSessionAtNextFrame),
  /// refused and why, or restored again after a restart in localization_only. Empty otherwise.
  std::string session_event;
  /// The frame was dropped (repeated or late stamp, see stamp_gate.h): not tracked, nothing to
  /// publish; result.message says why, pose is NaN and untrusted.
  bool dropped = false;
};

/// Trajectory as (stamp [ns], T_world_camera) pairs.
using PoseList = std::vector<std::pair<Timestamp, Eigen::Isometry3d>>;

class TrackingStage {
 public:
  /// Validates the options (std::invalid_argument).
  explicit TrackingStage(const TrackingOptions& options);

  /// Tracks `frame` against the map outside `mask` (CV_8UC1 255 = dynamic, empty = all static).
  /// Never throws on bad data (RgbdOdometry::track).
  /// `judgement`, `prepared`: see RgbdOdometry::track (features prepared ahead on another thread
  /// by a FeaturePreparer made with options(); the stage's lock is not needed for that).
  /// `frames_waiting`: frames queued behind this one (live callers; catch-up mode, see
  /// RgbdOdometry::track).
  TrackingOutput process(const RgbdFrame& frame, const cv::Mat& mask, MaskJudgement judgement = MaskJudgement::kUnknown,
                         const PreparedFeatures* prepared = nullptr, int frames_waiting = 0);

  /// End of the run, before the trajectories are saved: RgbdOdometry::finishRun (the local BA in
  /// flight, then the final global BA with TrackingOptions::global_ba_at_end). The recorded
  /// frames follow their keyframes; the corrections are for mapping.
  RunEnd finishRun();
  /// After finishRun: keyframe poses refined by the Gaussian map (pose_refinement) become the
  /// tracker's (RgbdOdometry::adoptKeyframePoses); the final trajectory follows them. Returns how
  /// many keyframes moved.
  std::size_t adoptKeyframePoses(const KeyframePoseCorrections& T_world_keyframe);

  /// Final trajectory: every recorded frame, following its keyframe's current pose.
  PoseList finalTrajectory() const;
  /// The poses as published at frame time.
  PoseList onlineTrajectory() const;
  /// The tracked frames only (not lost, not before initialisation) of the final trajectory,
  /// at most the newest `max_poses`.
  PoseList trackedPath(std::size_t max_poses) const;
  /// Current keyframe poses, in stamp order.
  PoseList keyframePoses() const;
  /// Frames recorded.
  std::size_t numFrames() const;
  /// Writes `dir`/trajectory.txt (final), trajectory_online.txt and keyframes.txt as TUM text,
  /// each atomically; returns the paths. Throws std::runtime_error naming a file it cannot write.
  std::vector<std::string> saveTrajectories(const std::string& dir) const;

  /// The tracker's state for a later session (RgbdOdometry::session; call finishRun() first).
  /// Throws std::logic_error before the first keyframe.
  TrackerSession session() const;
  /// Goes on from `session` in its world frame (RgbdOdometry::restoreSession): the recorded
  /// trajectory and the stamp gate start afresh (the resumed run records its own frames, with any
  /// stamps), and frames searching the restored map are not recorded until the camera is first
  /// found in it, or a new unanchored segment starts after max_lost_frames (before, they have no
  /// pose). Throws std::invalid_argument, the stage unchanged, when the
  /// session cannot be restored.
  void restoreSession(TrackerSession session);
  /// restoreSession on the next frame processed, once its camera is known (a live graph learns
  /// the camera from its first frame): a session for another camera (cameraMismatch) is dropped
  /// there and the tracker goes on as it was; TrackingOutput::session_event says which.
  void restoreSessionAtNextFrame(TrackerSession session);

  /// Forgets map, pose and trajectory (and a session waiting to be restored).
  void reset();
  /// Frames dropped for a repeated or late stamp since construction.
  std::size_t droppedOutOfOrder() const;
  /// The tracker (read it only from the thread that calls process()).
  const RgbdOdometry& odometry() const { return odometry_; }
  const TrackingOptions& options() const { return odometry_.options(); }

 private:
  mutable std::mutex mutex_;
  RgbdOdometry odometry_;
  TrajectoryRecorder recorder_;
  StampGate stamp_gate_;
  /// Restored, and the camera not yet found in the restored map: lost frames are not recorded.
  bool awaiting_first_pose_ = false;
  std::optional<TrackerSession> pending_session_;  ///< restoreSessionAtNextFrame's, until that frame
  /// localization_only: the restored session, restored again when the stamp jumps back.
  std::optional<TrackerSession> localization_session_;
  OdomFrame odom_;

  /// restoreSession with the lock held.
  void restoreLocked(TrackerSession session);
  /// The pending session restored for a frame of `camera`, or dropped; returns the event.
  std::string restorePending(const CameraIntrinsics& camera);
};

}  // namespace dypho::tracking
