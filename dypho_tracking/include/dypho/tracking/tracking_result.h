#pragma once
/// \file tracking_result.h
/// What `RgbdOdometry::track` returns for one frame.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/common/types.h"
#include "dypho/tracking/pose_covariance.h"

namespace dypho {
namespace tracking {

/// Whether a mask judged a frame's pixels (the safe start, TrackingOptions::first_keyframe_moving_hits).
enum class MaskJudgement {
  /// Not said by the caller: the frame counts as judged when its mask calls any pixel dynamic (an
  /// all-static mask may just mean that nothing could judge it yet).
  kUnknown,
  /// A mask of this very frame judged it (flow, network, external), even when it found nothing.
  kJudged,
  /// Nothing judged this frame's pixels: the flow's first frame without a network, or a mask
  /// carried over from another frame.
  kUnjudged,
};

/// State of the tracker after a frame.
enum class TrackingState {
  kNotInitialized,  ///< no keyframe yet (first frames, after reset, or unusable first frame)
  kOk,              ///< pose estimated for this frame
  kLost,            ///< a keyframe exists but this frame could not be registered to it
};

/// "NOT_INITIALIZED", "OK" or "LOST".
const char* toString(TrackingState state);

/// Wall-clock time spent in each stage of `track` [ms].
struct TrackingTimesMs {
  double features = 0;        ///< ORB extraction, undistortion and depth look-up, on the thread that prepared them [ms]
  double matching = 0;        ///< descriptor matching, guided and brute force [ms]
  double pnp = 0;             ///< PnP RANSAC (0 when the motion prediction was good enough) [ms]
  double refine = 0;          ///< Ceres motion-only refinement, all passes [ms]
  double local_ba = 0;        ///< local bundle adjustment and map-point culling (keyframes only) [ms]
  double loop = 0;            ///< loop detection, pose graph and map correction (keyframes only) [ms]
  double relocalization = 0;  ///< relocalisation against the map's keyframes (lost frames) [ms]
  double static_check = 0;    ///< dense check against the reference keyframe's static pixels [ms]
  double dense = 0;           ///< dense refinement against the reference keyframe [ms]
  double total = 0;           ///< whole `track` call [ms]
};

/// Result of tracking one frame.
struct TrackingResult {
  Timestamp stamp_ns = 0;                                ///< stamp of the frame [ns]
  TrackingState state = TrackingState::kNotInitialized;  ///< tracker state after this frame
  /// Camera optical frame in the world frame (world = first keyframe). When not kOk: the last good
  /// pose (identity before initialisation). Always finite.
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool is_keyframe = false;  ///< this frame became a new keyframe
  int num_features = 0;      ///< keypoints with valid depth in this frame [count]
  int num_matches = 0;       ///< keyframe-to-frame matches used for the final pose [count]
  int num_inliers = 0;       ///< pose inliers after the chi2 outlier rounds [count]
  /// How precisely this frame's inlier matches fix T_world_camera, relative to the map's points
  /// (poseCovariance); invalid on frames not tracked against the map (lost, the first keyframe,
  /// relocalised).
  PoseCovariance pose_covariance;
  double masked_fraction = 0;  ///< fraction of pixels marked dynamic in the mask [0, 1]
  KeyframeConstPtr keyframe;   ///< the new keyframe; non-null exactly when is_keyframe
  std::string message;         ///< why LOST / NOT_INITIALIZED / reset; empty when all went well
  bool relocalized = false;    ///< this frame was found again against the map after being lost
  bool loop_closed = false;    ///< a loop was closed at this (key)frame; see corrected_keyframes
  /// The pose jumped at this frame (first keyframe of a world, relocalised, re-initialised, reset
  /// by a stamp going backwards): no velocity may be formed across it (motion_prior.h).
  bool discontinuous = false;
  /// False from a re-initialisation (max_lost_frames lost frames: a new keyframe at the last good
  /// pose, the motion while lost unknown) until relocalisation or a loop closure ties the new
  /// keyframes to the map from before. The pose is then tracked, but relative to a guess: the
  /// stage hands it on as untrusted (no pose, tf or keyframe for the map).
  bool anchored = true;
  /// Earlier keyframes moved at this (key)frame by local BA or loop closure, by more than
  /// correction_min_translation_m / correction_min_rotation_rad: (keyframe id, new
  /// T_world_camera), one batch. Consumers (mapping) re-anchor those keyframes. Empty on frames
  /// that are not keyframes.
  KeyframePoseCorrections corrected_keyframes;
  /// Accumulated loop-closure correction: T_world_camera = T_world_odom * T_odom_camera, where
  /// odom is the uncorrected odometry frame (REP-105 map -> odom). Identity until a loop closes.
  Eigen::Isometry3d T_world_odom = Eigen::Isometry3d::Identity();
  /// The map moved under the earlier poses before this frame was tracked (a local BA applied
  /// late, TrackingOptions::local_ba_async_frames): T_world_after * T_world_before^-1; the
  /// previous frames' poses, as reported, are that much off in this frame's world. Consumers'
  /// motion models apply it to their last pose (PoseUpdate::T_correction). Identity otherwise.
  Eigen::Isometry3d T_correction = Eigen::Isometry3d::Identity();
  /// Keyframe this frame was tracked against (this frame's own id when it became a keyframe);
  /// -1 before initialisation. With T_reference_camera it lets a trajectory follow later local-BA
  /// and loop corrections of that keyframe (TrajectoryRecorder, as ORB-SLAM saves trajectories).
  std::int64_t reference_keyframe_id = -1;
  /// T_world_camera expressed in the reference keyframe, T_world_reference^-1 T_world_camera.
  Eigen::Isometry3d T_reference_camera = Eigen::Isometry3d::Identity();
  int num_map_points = 0;  ///< map points in the tracker's map [count]
  /// map points removed on this frame as moving (TrackingOptions::moving_point_min_hits) [count]
  int num_moving_points_removed = 0;
  int num_keyframes = 0;  ///< keyframes in the tracker's map [count]
  /// Share of the reference keyframe's static samples the final pose explains (TrackingOptions::
  /// static_check); -1 when not checked.
  double static_agreement = -1.0;
  /// The static check replaced the feature pose: moving matches had carried it.
  bool static_check_corrected = false;
  /// ... with the dense pose itself: the matches, re-estimated from it, preferred another pose.
  bool static_check_disputed = false;
  /// The dense refinement moved the feature pose by this much [m]; -1 when it did not run or
  /// its result was not taken (TrackingOptions::dense_refinement).
  double dense_correction_m = -1.0;
  /// Share of the reference keyframe's static samples the static check's refined pose explains
  /// beyond the feature pose when it did not replace it (too little gain, or the features
  /// contradicted it); 0 when not checked, not better, or corrected [-].
  double static_check_doubt = 0.0;
  /// Tracked in catch-up mode (TrackingOptions::catch_up_frames_waiting): frames were waiting
  /// behind this one, so a keyframe made on it had no local BA.
  bool caught_up = false;
  /// Matched features seen moving on this frame, at their measured depth in this frame's camera
  /// optical frame [m]: the matches the static check's pose does not explain when it corrected the
  /// feature pose (the coherent group that had carried it). Handed to the mask (MovingPoints) so
  /// that it covers the surface they lie on from the next frame on.
  std::vector<cv::Point3f> moving_points_camera_m;
  TrackingTimesMs times;  ///< stage timings [ms]
};

}  // namespace tracking
}  // namespace dypho
