#pragma once
/// \file session_store.h
/// A whole session on disk, to resume it or localise in it later (issue 36): the folder
/// `session/` holds
///   tracker.bin   the tracker's state (tracker_session.h: keyframes, map points, ids, poses),
///   map.ply       the Gaussian map (3DGS PLY, as MappingStage::save writes it),
///   session.yaml  the manifest, written last: format version, camera, counts, creation time and
///                 what the session came from.
/// Every file is written atomically and the manifest last (an old manifest is removed first), so
/// a folder with a valid manifest holds a complete session; a folder without one is refused.
/// ROS-free: the offline runner uses it, the nodelets can. docs/file_formats.md has the layout.

#include <cstdint>
#include <string>

#include "dypho/common/camera.h"
#include "dypho/pipeline/slam_pipeline.h"

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

/// What saveSession wrote.
struct SessionSaveReport {
  std::string dir;           ///< the session folder
  SessionManifest manifest;  ///< as written
  std::uint64_t bytes = 0;   ///< the three files together [bytes]
  double seconds = 0.0;      ///< wall time of the save [s]
};

/// Writes the session of `pipeline` to the folder `dir` (created): tracker.bin, map.ply, then
/// session.yaml. Call it at the end of a run, after SlamPipeline::finishTracking,
/// adoptMapKeyframePoses and the mapper's final refinement (finish()), so the saved poses and
/// map are final; it runs no refinement itself. `source`: free text for the manifest. Throws
/// std::logic_error without a map (PipelineOptions::build_map false) or before the tracker's
/// first keyframe, std::runtime_error naming a file it cannot write.
SessionSaveReport saveSession(SlamPipeline& pipeline, const std::string& dir, const std::string& source);

/// The session folder `path` names: `path` itself when it holds session.yaml, else
/// `path`/session (a run's output folder). Throws std::runtime_error when neither has a manifest.
std::string resolveSessionDir(const std::string& path);

/// Reads and checks `path` (a session.yaml). Throws std::runtime_error "session manifest
/// '<path>': <problem>" when it is missing, not YAML, another format version, or a field is
/// missing or invalid.
SessionManifest readSessionManifest(const std::string& path);

/// Loads the session folder `dir` into `pipeline` for the camera `run_camera`: the Gaussian map
/// replaces the mapper's (with PipelineOptions::build_map only), then the tracker is restored
/// (TrackingStage::restoreSession: it searches the loaded map from the next frame on). Refused
/// with std::runtime_error naming the file, and `pipeline` unchanged, when the manifest is
/// invalid or for another camera, tracker.bin or map.ply is missing, cut short or corrupt, or
/// their counts differ from the manifest's. Returns the manifest.
SessionManifest loadSession(SlamPipeline& pipeline, const std::string& dir, const CameraIntrinsics& run_camera);

}  // namespace dypho::pipeline
