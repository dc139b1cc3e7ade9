#pragma once
/// \file session_store.h
/// A whole in-process pipeline's session on disk, to resume it or localise in it later: the
/// folder session_folder.h describes (tracker.bin, map.ply, then session.yaml). ROS-free: the
/// offline runner uses it; the nodelets write and read the two halves apart (session_folder.h).

#include <cstdint>
#include <string>

#include "dypho/common/camera.h"
#include "dypho/pipeline/session_folder.h"
#include "dypho/pipeline/slam_pipeline.h"

namespace dypho::pipeline {

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

/// Loads the session folder `dir` into `pipeline` for the camera `run_camera`: the Gaussian map
/// replaces the mapper's (with PipelineOptions::build_map only), then the tracker is restored
/// (TrackingStage::restoreSession: it searches the loaded map from the next frame on). Refused
/// with std::runtime_error naming the file, and `pipeline` unchanged, when the manifest is
/// invalid or for another camera, tracker.bin or map.ply is missing, cut short or corrupt, or
/// their counts differ from the manifest's. Returns the manifest.
SessionManifest loadSession(SlamPipeline& pipeline, const std::string& dir, const CameraIntrinsics& run_camera);

}  // namespace dypho::pipeline
