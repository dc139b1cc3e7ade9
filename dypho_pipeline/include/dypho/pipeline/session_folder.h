#pragma once
/// \file session_folder.h
/// The session folder on disk, without the stages (issue 36): its layout, the manifest, and the
/// two halves that the graph's nodelets write and read each on its own side (the tracking
/// nodelet tracker.bin, the mapping nodelet map.ply). session_store.h saves and loads a whole
/// in-process pipeline with it. Depends on the tracking core only (tracker.bin is decoded to
/// count it), so the mapping nodelet needs no tracking code beyond the reader.
///
/// A folder holds
///   tracker.bin   the tracker's state (tracker_session.h: keyframes, map points, ids, poses),
///   map.ply       the Gaussian map (3DGS PLY),
///   session.yaml  the manifest, written last: format version, camera, counts, creation time and
///                 what the session came from.
/// A save removes the manifest first and writes it last, once both halves are there, so a folder
/// with a valid manifest holds a complete session and a folder without one is refused.
/// docs/file_formats.md has the layout.

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

#include "dypho/common/camera.h"
#include "dypho/tracking/tracker_session.h"

namespace dypho::pipeline {

/// Manifest format version this build writes and reads (another version is refused).
constexpr int kSessionFormatVersion = 1;
/// Names inside a session folder, and the folder's name inside a run's output folder.
constexpr const char* kSessionFolder = "session";
constexpr const char* kSessionManifestFile = "session.yaml";
constexpr const char* kSessionTrackerFile = "tracker.bin";
constexpr const char* kSessionMapFile = "map.ply";

/// The manifest (session.yaml): what a session holds, checked against its files when loaded.
struct SessionManifest {
  int format_version = kSessionFormatVersion;  ///< kSessionFormatVersion
  CameraIntrinsics camera;                     ///< the camera of the keyframes
  std::size_t num_keyframes = 0;               ///< tracker keyframes (removed ones not counted)
  std::size_t num_map_points = 0;              ///< tracker map points
  std::size_t num_gaussians = 0;               ///< Gaussians in map.ply
  std::string created_utc;                     ///< creation time, ISO 8601 UTC ("2026-11-28T09:12:51Z")
  std::string source;                          ///< what it came from (e.g. the dataset folder); free text
};

/// `dir`/`name` as a string.
std::string sessionFile(const std::string& dir, const char* name);

/// The session folder of the run output folder `run_dir` (`run_dir`/session).
inline std::string sessionFolderIn(const std::string& run_dir) { return sessionFile(run_dir, kSessionFolder); }

/// The session folder `path` names: `path` itself when it holds session.yaml, else
/// `path`/session (a run's output folder). Throws std::runtime_error when neither has a manifest.
std::string resolveSessionDir(const std::string& path);

/// Reads and checks `path` (a session.yaml). Throws std::runtime_error "session manifest
/// '<path>': <problem>" when it is missing, not YAML, another format version, or a field is
/// missing or invalid.
SessionManifest readSessionManifest(const std::string& path);

/// Writes `manifest` to `dir`/session.yaml atomically (created_utc is filled in when empty).
void writeSessionManifest(const std::string& dir, SessionManifest manifest);

/// The vertex count in the header of the PLY at `path` (the header only); throws
/// std::runtime_error naming the file when it has none.
std::size_t plyVertexCount(const std::string& path);

/// Starts a save into `dir`: creates it and removes its manifest, so that a crash part way never
/// leaves an old manifest beside new files. Throws std::runtime_error when `dir` cannot be made.
void beginSessionSave(const std::string& dir);

/// Completes the session in `dir` once both halves are there: writes session.yaml for the
/// tracker.bin and map.ply in it when each exists and was written at or after `since` (minus 1 s,
/// file-system clocks are coarse), with the counts read from the files themselves. The two
/// nodelets call it after writing their half, in either order and from either process (a lock
/// file in `dir` serialises them); the second call writes the manifest. Returns the manifest
/// written, or nothing with `*why` saying which half is missing or older. Throws
/// std::runtime_error when a half is there but unreadable (corrupt tracker.bin, no PLY header).
std::optional<SessionManifest> completeSession(const std::string& dir, std::filesystem::file_time_type since,
                                               const std::string& source, std::string* why = nullptr);

/// The tracker half of the session folder `dir`, for the camera `run_camera`, checked against
/// `manifest` (camera and counts). Throws std::runtime_error naming the file on any problem.
tracking::TrackerSession readSessionTracker(const std::string& dir, const SessionManifest& manifest,
                                            const CameraIntrinsics& run_camera);

/// The path of the map half of the session folder `dir` after checking its Gaussian count
/// against `manifest`. Throws std::runtime_error naming the file when it is missing or differs.
std::string checkedSessionMap(const std::string& dir, const SessionManifest& manifest);

/// Files of `dir` together [bytes] (tracker.bin, map.ply, session.yaml; 0 for a missing one).
std::uint64_t sessionBytes(const std::string& dir);

}  // namespace dypho::pipeline
