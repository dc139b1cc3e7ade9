#pragma once
/// \file rgbd_odometry.h
/// Frame-to-keyframe RGB-D visual odometry: the public entry point of dypho_tracking_core.

#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <map>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/motion_prior.h"
#include "dypho/common/types.h"
#include "dypho/tracking/feature_preparer.h"
#include "dypho/tracking/final_frame_refiner.h"
#include "dypho/tracking/dense_rgbd_aligner.h"
#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/global_bundle_adjuster.h"
#include "dypho/tracking/keyframe_aligner.h"
#include "dypho/tracking/keyframe_points.h"
#include "dypho/tracking/keyframe_selector.h"
#include "dypho/tracking/local_bundle_adjuster.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/tracker_session.h"
#include "dypho/tracking/loop_closer.h"
#include "dypho/tracking/loop_detector.h"
#include "dypho/tracking/orb_extractor.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/pose_optimizer.h"
#include "dypho/tracking/relocalizer.h"
#include "dypho/tracking/static_scene_check.h"
#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {

/// What RgbdOdometry::finishRun did.
struct RunEnd {
  /// The final global BA (TrackingOptions::global_ba_at_end); ran = false when off or when the
  /// map has nothing to adjust (message says why).
  GlobalBaResult global_ba;
  /// Keyframes moved since they were last reported (the local BA in flight, the global BA), for
  /// mapping to re-anchor, as TrackingResult::corrected_keyframes.
  KeyframePoseCorrections corrected_keyframes;
  /// Each frame's pose optimised again against the final map (TrackingStage::finishRun,
  /// TrackingOptions::final_frame_refinement).
  FrameRefinementResult frame_refinement;
};

/// RGB-D visual odometry against a local map, with local BA, relocalisation and loop closure.
///
/// Per frame: ORB features outside the dynamic mask (OrbExtractor) -> undistort + depth
/// (makeFrameFeatures) -> pose against the LOCAL MAP, i.e. the map points of the last keyframe
/// and its local_map_keyframes most covisible keyframes (KeyframeAligner: constant-velocity
/// prediction, projection matching with scale prediction, PnP RANSAC fallback on the last
/// keyframe's own points, Ceres motion-only BA with chi2 rounds) -> visibility bookkeeping ->
/// KeyframeSelector. On a new keyframe: TrackerMap::addKeyframe (RGB-D points, matched points get
/// a new observation), then LocalBundleAdjuster, map-point culling, redundant-keyframe culling,
/// LoopDetector + LoopCloser (pose graph; corrected keyframes in the result). Local BA runs on
/// its own thread on a copy of its window (TrackingOptions::local_ba_async_frames); its result
/// and the steps after it are applied a fixed number of frames later, on the calling thread, so
/// the map is only ever changed there and runs stay repeatable.
///
/// State machine:
///  - NOT_INITIALIZED: the first frame with >= min_init_features keypoints with depth becomes
///    keyframe 0 at T_world_camera = identity (this frame returns OK, is_keyframe).
///  - OK: frame registered; may become a keyframe.
///  - LOST: registration failed; Relocalizer tries the map's keyframes (result.relocalized and OK
///    when it succeeds; the velocity is dropped). Otherwise the last good pose is returned. After
///    max_lost_frames consecutive failures, the next frame with enough features becomes a new
///    keyframe at the last good pose (re-initialisation; not connected to the old map points, so
///    the jump while lost is not recovered unless a loop closes later).
///  - After restoreSession (a saved session, tracker_session.h): every frame is relocalised
///    against the loaded map, every candidate keyframe tried and the one with most inliers taken
///    (kLost until found, result.relocalized when found, then OK as above); max_lost_frames
///    failures re-initialise as from LOST.
///  - TrackingOptions::localization_only: the same, but the map is never changed (no keyframes,
///    points, culling, BA, loop closure); tracked frames move the reference to the keyframe that
///    sees most of their inliers; lost frames relocalise in the map, never re-initialise; with
///    no restored map nothing is tracked (kNotInitialized, the message says why). Once found, a
///    pose (tracked or relocalised) far from the frame's prediction on few inliers is refused:
///    the frame is lost (localization_max_jump_m/deg, localization_confident_inliers).
///  - A stamp not after the previous one (time going backwards or repeated) resets everything:
///    NOT_INITIALIZED, identity pose, message; the following frame starts a new world.
///
/// Not thread-safe: call `track` from one thread (the local BA thread reads only its own copy).
class RgbdOdometry {
 public:
  /// Throws std::invalid_argument when options.validate() does.
  explicit RgbdOdometry(const TrackingOptions& options);

  /// mask: CV_8UC1 255 = dynamic (no features there), or empty = all static. Never throws on
  /// bad data: returns a result with state kLost/kNotInitialized and a message (no valid depth,
  /// all masked, textureless, wrong types/sizes, stamp not after the previous one -> reset +
  /// message). Never returns a NaN pose. `judgement`: whether `mask` judged this frame (only the
  /// safe start reads it: a first keyframe nothing judged has its points verified).
  /// `prepared`: this frame's features from a FeaturePreparer with the same options (e.g. made on
  /// another thread while the previous frame was tracked); null, invalid or prepared for another
  /// stamp: they are prepared here. The result is the same either way.
  /// `frames_waiting`: frames queued behind this one (a live caller that fell behind the camera);
  /// from TrackingOptions::catch_up_frames_waiting on, the frame is tracked in catch-up mode
  /// (TrackingResult::caught_up). Offline callers pass 0.
  TrackingResult track(const RgbdFrame& frame, const cv::Mat& mask, MaskJudgement judgement = MaskJudgement::kUnknown,
                       const PreparedFeatures* prepared = nullptr, int frames_waiting = 0);

  /// End of a run (offline runner after the last frame, nodelet at shutdown): applies the local
  /// BA in flight, then, with TrackingOptions::global_ba_at_end, a global BA of the whole map
  /// (GlobalBundleAdjuster). The last pose keeps its place relative to its reference keyframe
  /// and the local-map views are rebuilt, so tracking may go on after it. Call it before saving
  /// a trajectory: trajectories re-expressed on their keyframes (TrajectoryRecorder) follow it.
  RunEnd finishRun();
  /// After finishRun: each of `records` (this run's frames) optimised again against the final
  /// map (FinalFrameRefiner; TrackingOptions::final_frame_refinement).
  FrameRefinementResult refineRecordedPoses(std::vector<RecordedPose>* records) const;

  /// Takes keyframe poses refined elsewhere (the Gaussian map's joint refinement) as the map's
  /// own: the keyframes move there, their map points with them (TrackerMap::applyKeyframePoses),
  /// the last pose keeps its place relative to the reference keyframe, and no correction goes
  /// back for them (they are the poses mapping already has). Unknown ids and non-finite poses are
  /// ignored; returns how many keyframes moved. Call it after finishRun, before saving.
  std::size_t adoptKeyframePoses(const KeyframePoseCorrections& T_world_keyframe);

  /// Global BA calls so far (after loops and at the end), for run summaries.
  const GlobalBaStats& globalBaStats() const { return global_ba_stats_; }

  /// Forgets map, pose and velocity; the next usable frame starts a new world at identity.
  /// Keyframe and map-point ids keep increasing (unique over the object's life).
  void reset();

  /// The tracker's state for a later session (tracker_session.h, saveTrackerSession): map, id
  /// counters, camera, last pose, loop bookkeeping. A local BA still in flight is not in it: at
  /// the end of a run call finishRun() first. Throws std::logic_error before the first keyframe
  /// (there is nothing to go on from).
  TrackerSession session() const;

  /// Goes on from `session` in its world frame (e.g. loadTrackerSession): forgets the current
  /// state (reset), takes the session's map, ids and bookkeeping, then searches the loaded map:
  /// each frame is relocalised against its keyframes (TrackingResult::relocalized) and is kLost
  /// until one is found; after max_lost_frames failures a new segment starts at the session's
  /// last pose, unanchored (as after a loss). The next frame may have any stamp (a later day).
  /// New keyframe and map-point ids continue above the session's. Throws std::invalid_argument
  /// with trackerSessionProblem's reason, the tracker unchanged, when it cannot be restored.
  void restoreSession(TrackerSession session);

  /// The options in use.
  const TrackingOptions& options() const { return options_; }

  /// The tracker's map (keyframes with their current poses, map points).
  const TrackerMap& map() const { return map_; }

 private:
  /// One frame's working state between the steps of track() (src/core/rgbd_odometry_frame.h).
  struct TrackingFrame;

  // The steps of track(), in order (src/core/rgbd_odometry_track.cpp). Each reads the
  // TrackingFrame fields of the steps before it and writes its own.
  /// Catch-up mode and the result's defaults: the last pose, kLost (kNotInitialized without a map).
  void beginFrame(int frames_waiting, TrackingFrame* work);
  /// False, with the message, when the frame's images or camera are unusable (checkTrackingInput);
  /// a frame after the start then counts as lost.
  bool admitInput(TrackingFrame* work);
  /// Records the stamp; false after a reset when it is not after the previous one.
  bool admitStamp(TrackingFrame* work);
  /// The frame's keypoints with depth: the caller's `prepared` when they are this frame's, else
  /// prepared here; whether there are enough to start a map and to match.
  void prepareFeatures(const PreparedFeatures* prepared, TrackingFrame* work);
  /// Without a map: the frame becomes keyframe 0 of a new world (or the message says why not).
  void startMap(TrackingFrame* work);
  /// Predict: refreshes stale local-map views; the motion model's pose at the frame's stamp (the
  /// last pose without a velocity).
  void predictPose(TrackingFrame* work);
  /// Match and optimise: the feature pose against the local map (KeyframeAligner) from the
  /// prediction, or why there are too few features.
  void matchAndOptimise(TrackingFrame* work);
  /// The camera's turn since the last frame (motion model) or since the reference keyframe (image)
  /// [deg]; -1 when unknown.
  double frameTurnDeg(const TrackingFrame& work) const;
  /// Verify: the static check of the feature pose on slow frames (checkAgainstStaticScene), then
  /// the pose as T_world_camera.
  void verifyPose(TrackingFrame* work);
  /// Refine: the dense alignment to the reference keyframe with the feature pose as its prior
  /// (TrackingOptions::dense_refinement); the pose is replaced when the correction is plausible.
  void refineDensely(TrackingFrame* work);
  /// TrackingOptions::localization_only: why a pose with `num_inliers` inliers, tracked or
  /// relocalised, is refused: it lies farther from the frame's prediction than
  /// localization_max_jump_m/deg allow (times the frames since the last good pose). Empty when it
  /// is accepted, always while a restored map is searched (no prediction) and from
  /// localization_confident_inliers inliers on.
  std::string strayFromPrediction(const TrackingFrame& work, const Eigen::Isometry3d& T_world_camera,
                                  int num_inliers) const;
  /// A tracked frame: the motion model, the last pose and the counters take its pose.
  void acceptPose(TrackingFrame* work);
  /// Decide keyframe: KeyframeSelector on the tracked pose against the reference keyframe.
  KeyframeDecision decideKeyframe(const TrackingFrame& work) const;
  /// Local map: the tracked frame becomes a keyframe, with its inlier matches as observations.
  void insertKeyframe(TrackingFrame* work);
  /// TrackingOptions::localization_only, a tracked frame: the map is left as it is; the keyframe
  /// that observes most of the frame's inlier points becomes the reference.
  void followMap(const TrackingFrame& work);
  /// After restoreSession: relocalisation against the loaded map without tracking first (the
  /// camera may be anywhere in it); the frame is lost when that fails.
  void searchMap(TrackingFrame* work);
  /// Lost: relocalisation against the map's keyframes; true when it found the frame.
  bool relocalise(TrackingFrame* work);
  /// A lost frame: counted, the motion model told; after max_lost_frames, re-initialisation.
  void markLost(TrackingFrame* work);
  /// A new keyframe at the last good pose after too many lost frames (not anchored to the map).
  void reinitialise(TrackingFrame* work);
  /// With a rolling shutter, after startMap / reinitialise: the new keyframe's frame is kept until
  /// a frame is tracked against it (uncompensated_start_).
  void holdUncompensatedStart(const TrackingFrame& work);
  /// The first frame tracked against a keyframe that started a map without a velocity: the step
  /// between them gives the start's velocities. When their skew stands above the step's noise
  /// (10 px top to bottom), the keyframe's keypoints and its own points are remade as its camera
  /// at the stamp saw them (compensateRollingShutter), as every later keyframe's are. The frame
  /// keeps its pose and takes the step's velocities: it was matched against the skewed points, so
  /// its own estimate is the difference of two skews. The following frames match the remade
  /// points; the keyframe mapping already received keeps its keypoints.
  void compensateStartKeyframe(TrackingFrame* work);
  /// The result's map and reference fields and the total time; returns the result.
  TrackingResult finishFrame(TrackingFrame* work) const;

  /// The camera moved less than 5 mm and 0.2 deg between the last two tracked frames
  /// (TrackingOptions::moving_point_still_only).
  bool cameraStill() const;
  /// Explains why a frame has too few keypoints with depth.
  std::string explainFewFeatures(const RgbdFrame& frame, const OrbFeatures& orb, const FrameFeatures& features) const;
  /// Adds `features` as a new keyframe at T_world_camera (map_point_ids per feature: the matched
  /// map point or -1), runs local BA, point and keyframe culling and loop closure, fills the result fields.
  /// T_world_tracked is taken by value: it may be the last pose, which a local BA finished here
  /// moves. blur_rates / blur_exposure_s: the frame's motion blur as the pose refinement weighted
  /// it (MapKeyframe::blur_rates); an exposure of 0 = sharp.
  void addKeyframe(const RgbdFrame& frame, const cv::Mat& mask, const FrameFeatures& features,
                   Eigen::Isometry3d T_world_tracked, const std::vector<std::int64_t>& map_point_ids,
                   const Pinhole& pinhole, TrackingResult* result, const CameraRates& blur_rates = CameraRates(),
                   double blur_exposure_s = 0.0);
  /// Keyframes (other than the new one) whose pose moved by more than the correction thresholds
  /// since it was last reported, appended to result->corrected_keyframes; the pose mapping holds
  /// thus never differs from the tracker's by more than those thresholds.
  void collectCorrections(std::int64_t new_keyframe_id, TrackingResult* result);
  /// Removes the redundant keyframes of the newest keyframe's local map (not the oldest keyframe,
  /// nor `keep_id`).
  void cullKeyframes(std::int64_t newest_keyframe_id, std::int64_t keep_id = -1);
  /// Map-point and keyframe culling, then loop closure, after local BA of `keyframe_id`.
  void afterLocalBa(std::int64_t keyframe_id, std::int64_t keep_id, const Pinhole& pinhole, TrackingResult* result);
  /// The local BA in flight, if any: waits for it, writes it into the map, runs afterLocalBa and
  /// keeps the last pose where it was relative to the reference keyframe; corrections go into
  /// `result`. Returns the correction applied to the last pose (T_world_after * T_world_before^-1;
  /// identity when nothing was in flight), for poses computed against the map before.
  Eigen::Isometry3d finishLocalBa(const Pinhole& pinhole, TrackingResult* result);
  /// Loop detection and correction for the newest keyframe.
  void closeLoops(std::int64_t keyframe_id, const Pinhole& pinhole, TrackingResult* result);
  /// Global BA of the whole map (src/core/rgbd_odometry_global_ba.cpp), timed into the stats.
  /// Holds the oldest keyframe fixed, and the first keyframe of an unanchored segment.
  GlobalBaResult runGlobalBa();
  /// The keyframes besides the oldest that a global BA holds fixed: the first keyframe of a
  /// re-initialised segment not yet tied to the map by a loop (its gauge is free).
  std::set<std::int64_t> globalBaExtraFixed() const;
  /// After a loop (TrackingOptions::global_ba_after_loop): a global BA; the loop correction of
  /// the odometry frame takes the current keyframe's move. The caller's correction of the last
  /// pose and of the views (addKeyframe, finishLocalBa) covers the rest.
  void globalBaAfterLoop(std::int64_t keyframe_id, TrackingResult* result);
  /// Makes `keyframe_id` the reference and rebuilds the local-map views.
  void setReference(std::int64_t keyframe_id);
  /// Bookkeeping after a tracked frame: visible / found counts of the local map's points, and
  /// the moving-point test (TrackingOptions::moving_point_min_hits) with its culling.
  void updatePointStatistics(const AlignmentResult& aligned, const Pinhole& pinhole, const FrameFeatures& features,
                             const RgbdFrame& frame, const cv::Mat& mask, TrackingResult* result);
  /// Where the static check's dense refinement starts: the feature pose, or the last pose or the
  /// reference keyframe's pose when one explains more of the static samples
  /// (TrackingOptions::static_check_other_starts). T_camera_world poses.
  Eigen::Isometry3d denseStart(const Eigen::Isometry3d& T_features, double features_agreement,
                               const Eigen::Isometry3d& T_world_reference) const;
  /// TrackingOptions::static_check: compares the feature pose in `aligned` with the dense
  /// refinement against the reference keyframe's static pixels; when the refinement explains
  /// clearly more of them, re-estimates the pose from the matches that agree with it.
  void checkAgainstStaticScene(const RgbdFrame& frame, const cv::Mat& mask, const FrameFeatures& features,
                               const Pinhole& pinhole, AlignmentResult* aligned, TrackingResult* result);

  TrackingOptions options_;
  bool catching_up_ = false;  ///< the frame in track() is in catch-up mode (TrackingOptions::catch_up_*)
  bool views_stale_ = false;  ///< points of local_view_/own_view_ were removed: refresh them
  FeaturePreparer preparer_;  ///< features of frames that come without prepared ones
  KeyframeAligner aligner_;
  KeyframeSelector selector_;
  TrackerMap map_;
  LocalBundleAdjuster local_ba_;
  Relocalizer relocalizer_;
  LoopDetector loop_detector_;
  LoopCloser loop_closer_;
  GlobalBundleAdjuster global_ba_;
  GlobalBaStats global_ba_stats_;
  Pinhole pinhole_;          ///< the camera of the keyframes (set with the first keyframe)
  CameraIntrinsics camera_;  ///< the same camera with its image size and distortion (for sessions)
  bool has_pinhole_ = false;
  /// A restored session's map is searched by relocalisation until the camera is found in it.
  bool searching_map_ = false;
  PoseOptimizer pose_optimizer_;     ///< re-estimation after the static check; pose covariance, dense prior
  StaticSceneCheck static_check_;    ///< dense check against the reference keyframe
  DenseRgbdAligner dense_;           ///< dense refinement against the reference keyframe
  FinalFrameRefiner frame_refiner_;  ///< the tracked frames' evidence, for refineRecordedPoses
  /// Local BA in flight (local_ba_async_frames > 0); declared after local_ba_, which it uses.
  std::future<LocalBaSolution> pending_ba_;
  std::int64_t pending_ba_keyframe_id_ = -1;
  int pending_ba_frames_left_ = 0;  ///< frames until it is applied

  std::int64_t reference_id_ = -1;  ///< keyframe tracked against; -1 before initialisation
  KeyframePoints local_view_;       ///< map points of the reference's local map (TrackerMap::trackingPoints)
  KeyframePoints own_view_;         ///< the reference keyframe's own points (PnP fallback)
  Eigen::Isometry3d T_world_last_ = Eigen::Isometry3d::Identity();  ///< last good pose
  ConstantVelocityModel motion_;  ///< the shared constant-velocity prediction (motion_prior.h)
  std::map<std::int64_t, Eigen::Isometry3d> reported_poses_;        ///< keyframe poses last handed on
  Eigen::Isometry3d T_world_odom_ = Eigen::Isometry3d::Identity();  ///< loop corrections so far
  bool has_stamp_ = false;
  Timestamp last_stamp_ns_ = 0;
  int frames_since_keyframe_ = 0;
  int reference_inliers_ = 0;  ///< inliers of the first frame tracked against the keyframe
  int lost_frames_ = 0;
  std::int64_t next_keyframe_id_ = 0;
  std::int64_t last_loop_keyframe_id_ = -1;  ///< keyframe where the last loop closed
  /// First keyframe of a re-initialised segment not yet tied to the earlier map; -1 = anchored.
  std::int64_t unanchored_from_keyframe_id_ = -1;
  /// A keyframe that started a map (or a re-initialised segment) under a rolling shutter: its
  /// keypoints carry the skew of a turn not yet known, until compensateStartKeyframe.
  struct UncompensatedStart {
    std::int64_t keyframe_id = -1;
    Timestamp stamp_ns = 0;
    cv::Mat depth_m;  ///< its depth image (a copy: the caller may reuse the frame's buffer)
    CameraIntrinsics camera;
  };
  std::optional<UncompensatedStart> uncompensated_start_;
  /// First keyframe after a start / re-initialisation while its points are unverified
  /// (TrackingOptions::first_keyframe_moving_hits); -1 when none.
  std::int64_t unverified_keyframe_id_ = -1;
};

}  // namespace tracking
}  // namespace dypho
