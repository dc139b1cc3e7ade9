#pragma once
/// \file tracker_session.h
/// The tracker's state as a file, to go on later in the same world frame: save a session, resume
/// it, localise in yesterday's map (RgbdOdometry::session / restoreSession).
///
/// File format (version 2, every number little-endian; docs/file_formats.md has the full layout):
///   header, 32 bytes: magic "DYPHOTRK", u32 format version, u32 reserved (0),
///                     u64 payload length [bytes], u64 FNV-1a 64 of the payload;
///   payload: camera, tracker counters and poses, keyframes (with their features), map points
///            (with their observations), removed keyframes, keyframe poses last reported; in id
///            order, so the same state always gives the same bytes.
/// Poses are stored as their 3x4 matrix (f64), so a saved and loaded state is the same to the bit.

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include <Eigen/Geometry>

#include "dypho/common/camera.h"
#include "dypho/common/types.h"
#include "dypho/tracking/tracker_map.h"

namespace dypho {
namespace tracking {

/// Format version this build writes. It reads this one and kTrackerSessionOldestVersion (version
/// 1 has no keyframe blur: its keyframes load as sharp); another version is refused.
constexpr std::uint32_t kTrackerSessionVersion = 2;
constexpr std::uint32_t kTrackerSessionOldestVersion = 1;
/// Bytes of the header before the payload.
constexpr std::size_t kTrackerSessionHeaderBytes = 32;

/// Everything the tracker needs to go on in the same world frame. What is not here is derived:
/// covisibility (from the observations), the local-map views (from the map), and what loop
/// detection and relocalisation search (the keyframes' poses, features and descriptors). Not
/// kept: the motion model and the reference keyframe's images of the static check and the dense
/// refinement (a restored tracker first relocalises, then makes new keyframes with images).
struct TrackerSession {
  /// The camera of the keyframes (their features are undistorted with it); a session is loaded
  /// for this camera only.
  CameraIntrinsics camera;
  /// Keyframes (pose, features, map-point ids), map points, removed keyframes, next point id.
  TrackerMapState map;
  std::int64_t next_keyframe_id = 0;              ///< next free keyframe id (above every id in use)
  std::int64_t last_loop_keyframe_id = -1;        ///< keyframe where the last loop closed; -1 = none
  std::int64_t unanchored_from_keyframe_id = -1;  ///< first keyframe of an unanchored segment; -1 = anchored
  /// Stamp of the last frame before the save [ns] (for the caller, e.g. where a run resumes;
  /// restoreSession does not use it: a later session may have any stamps). 0 = none.
  Timestamp last_stamp_ns = 0;
  Eigen::Isometry3d T_world_last = Eigen::Isometry3d::Identity();  ///< last good camera pose
  Eigen::Isometry3d T_world_odom = Eigen::Isometry3d::Identity();  ///< loop corrections so far
  /// Keyframe poses as last handed to mapping (TrackingResult::corrected_keyframes is relative
  /// to them), removed keyframes included.
  std::map<std::int64_t, Eigen::Isometry3d> reported_poses;
};

/// The first reason `session` cannot be restored, empty when it can: an invalid camera, no
/// keyframe, a map that trackerMapStateProblem refuses, a keyframe id not below
/// next_keyframe_id, a non-finite or non-rigid pose.
std::string trackerSessionProblem(const TrackerSession& session);

/// Empty when `session_camera` and `run_camera` are the same camera: the same image size and
/// every intrinsic and distortion number within 1e-6 relative (distortion: of max(1, |value|));
/// otherwise what differs.
std::string cameraMismatch(const CameraIntrinsics& session_camera, const CameraIntrinsics& run_camera);

/// The file's bytes for `session` (header and payload). Throws std::invalid_argument with
/// trackerSessionProblem's reason when it cannot be restored (nothing is written that could not
/// be loaded).
std::string encodeTrackerSession(const TrackerSession& session);

/// Reads the file's bytes `bytes` for the camera `run_camera`. Throws std::runtime_error
/// "cannot load '<source>': <problem>" when they are no session, are cut short or too long, fail
/// the checksum, are another format version, hold a count larger than the bytes left (checked
/// before anything is allocated), fail trackerSessionProblem, or are for another camera
/// (cameraMismatch). Never crashes on arbitrary bytes.
TrackerSession decodeTrackerSession(const std::string& bytes, const CameraIntrinsics& run_camera,
                                    const std::string& source);

/// Writes `session` to `path` atomically (writeFileAtomically: readers see the old file or the
/// whole new one). Throws std::invalid_argument as encodeTrackerSession, std::runtime_error
/// naming the path when it cannot be written.
void saveTrackerSession(const std::string& path, const TrackerSession& session);

/// Reads the session at `path` for the camera `run_camera` (decodeTrackerSession; also throws
/// when the file cannot be read). Returns a new state: nothing of the caller's changes on error.
TrackerSession loadTrackerSession(const std::string& path, const CameraIntrinsics& run_camera);

/// As loadTrackerSession for the camera the file was saved with (every other check holds): to
/// count what a file holds without a run's camera.
TrackerSession loadTrackerSessionAnyCamera(const std::string& path);

/// FNV-1a 64 of `size` bytes: the checksum the header holds for the payload.
std::uint64_t trackerSessionChecksum(const char* data, std::size_t size);

}  // namespace tracking
}  // namespace dypho
