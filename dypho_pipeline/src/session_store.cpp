/// The session folder: tracker.bin, map.ply and the manifest session.yaml written last.
#include "dypho/pipeline/session_store.h"

#include <chrono>
#include <stdexcept>

#include "dypho/tracking/tracker_session.h"

namespace dypho::pipeline {
SessionSaveReport saveSession(SlamPipeline& pipeline, const std::string& dir, const std::string& source) {
  if (!pipeline.options().build_map) throw std::logic_error("saveSession: no map was built (build_map false)");
  const auto t0 = std::chrono::steady_clock::now();
  const tracking::TrackerSession session = pipeline.tracking().session();  // throws before a keyframe
  beginSessionSave(dir);
  const std::string map_path = sessionFile(dir, kSessionMapFile);
  tracking::saveTrackerSession(sessionFile(dir, kSessionTrackerFile), session);
  pipeline.mapping().gaussians().savePly(map_path);

  SessionSaveReport report;
  report.dir = dir;
  SessionManifest& m = report.manifest;
  m.camera = session.camera;
  m.num_keyframes = session.map.keyframes.size();
  m.num_map_points = session.map.points.size();
  m.num_gaussians = plyVertexCount(map_path);  // what the file holds
  m.source = source;
  writeSessionManifest(dir, m);
  report.manifest = readSessionManifest(sessionFile(dir, kSessionManifestFile));
  report.bytes = sessionBytes(dir);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

SessionManifest loadSession(SlamPipeline& pipeline, const std::string& dir, const CameraIntrinsics& run_camera) {
  const SessionManifest m = readSessionManifest(sessionFile(dir, kSessionManifestFile));
  // Everything is read and checked before anything of the pipeline changes.
  tracking::TrackerSession session = readSessionTracker(dir, m, run_camera);
  if (pipeline.options().build_map) {
    const std::string map_path = checkedSessionMap(dir, m);
    try {
      pipeline.mapping().loadMap(map_path);  // reads the whole file first; the map is kept on error
    } catch (const std::exception& e) {
      throw std::runtime_error("cannot load '" + map_path + "': " + e.what());
    }
  }
  // Checked by loadTrackerSession (trackerSessionProblem): restoring cannot fail now.
  pipeline.tracking().restoreSession(std::move(session));
  return m;
}

}  // namespace dypho::pipeline
