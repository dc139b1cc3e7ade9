/// The session folder: tracker.bin, map.ply and the manifest session.yaml written last.
#include "dypho/pipeline/session_store.h"

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "dypho/common/atomic_file.h"
#include "dypho/tracking/tracker_session.h"

namespace dypho::pipeline {
namespace {

namespace fs = std::filesystem;

std::string join(const std::string& dir, const char* name) { return (fs::path(dir) / name).string(); }

std::string utcNow() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::ostringstream os;
  os << std::put_time(&tm, "%Y-%m-%dT%H:%M:%SZ");
  return os.str();
}

/// A YAML double-quoted string (the source may hold any characters).
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

void writeManifest(const std::string& path, const SessionManifest& m) {
  writeFileAtomically(path, [&](std::ostream& os) {
    os << std::setprecision(17);
    os << "# DyPho-SLAM session manifest (docs/file_formats.md), written after tracker.bin and map.ply\n"
       << "format_version: " << m.format_version << "\n"
       << "created_utc: " << quoted(m.created_utc) << "\n"
       << "source: " << quoted(m.source) << "\n"
       << "camera:\n"
       << "  width: " << m.camera.width << "\n  height: " << m.camera.height << "\n"
       << "  fx: " << m.camera.fx << "\n  fy: " << m.camera.fy << "\n  cx: " << m.camera.cx << "\n  cy: " << m.camera.cy
       << "\n  distortion: [" << m.camera.distortion[0];
    for (std::size_t i = 1; i < m.camera.distortion.size(); ++i) os << ", " << m.camera.distortion[i];
    os << "]\n"
       << "keyframes: " << m.num_keyframes << "\n"
       << "map_points: " << m.num_map_points << "\n"
       << "gaussians: " << m.num_gaussians << "\n";
  });
}

/// The vertex count in the header of the PLY at `path` (cheap: the header only); throws naming
/// the file when there is none.
std::size_t plyVertexCount(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read '" + path + "' (missing?)");
  std::string line;
  for (int i = 0; i < 200 && std::getline(in, line); ++i) {
    std::istringstream words(line);
    std::string a, b;
    std::size_t n = 0;
    if (words >> a >> b >> n && a == "element" && b == "vertex") return n;
    if (line.rfind("end_header", 0) == 0) break;
  }
  throw std::runtime_error("'" + path + "' is not a 3DGS PLY (no 'element vertex' in its header)");
}

std::uint64_t fileBytes(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t n = fs::file_size(path, ec);
  return ec ? 0 : static_cast<std::uint64_t>(n);
}

}  // namespace

SessionSaveReport saveSession(SlamPipeline& pipeline, const std::string& dir, const std::string& source) {
  if (!pipeline.options().build_map) throw std::logic_error("saveSession: no map was built (build_map false)");
  const auto t0 = std::chrono::steady_clock::now();
  const tracking::TrackerSession session = pipeline.tracking().session();  // throws before a keyframe
  fs::create_directories(dir);
  // A crash part way must not leave an old manifest beside new files: it goes first, comes last.
  const std::string manifest_path = join(dir, kSessionManifestFile);
  std::error_code ec;
  fs::remove(manifest_path, ec);
  const std::string tracker_path = join(dir, kSessionTrackerFile);
  const std::string map_path = join(dir, kSessionMapFile);
  tracking::saveTrackerSession(tracker_path, session);
  pipeline.mapping().gaussians().savePly(map_path);

  SessionSaveReport report;
  report.dir = dir;
  SessionManifest& m = report.manifest;
  m.camera = session.camera;
  m.num_keyframes = session.map.keyframes.size();
  m.num_map_points = session.map.points.size();
  m.num_gaussians = plyVertexCount(map_path);  // what the file holds
  m.created_utc = utcNow();
  m.source = source;
  writeManifest(manifest_path, m);
  report.bytes = fileBytes(tracker_path) + fileBytes(map_path) + fileBytes(manifest_path);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

std::string resolveSessionDir(const std::string& path) {
  if (fs::is_regular_file(join(path, kSessionManifestFile))) return path;
  const std::string nested = join(path, kSessionFolder);
  if (fs::is_regular_file(join(nested, kSessionManifestFile))) return nested;
  throw std::runtime_error("no session in '" + path + "': neither '" + join(path, kSessionManifestFile) + "' nor '" +
                           join(nested, kSessionManifestFile) +
                           "' exists (a session folder is complete only once its manifest is written)");
}

SessionManifest readSessionManifest(const std::string& path) {
  const auto fail = [&](const std::string& problem) {
    return std::runtime_error("session manifest '" + path + "': " + problem);
  };
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw fail("cannot be read (missing?)");
  } catch (const YAML::Exception& e) {
    throw fail(std::string("not valid YAML: ") + e.what());
  }
  if (!root.IsMap()) throw fail("not a map of key: value");
  SessionManifest m;
  try {
    m.format_version = root["format_version"].as<int>();
    if (m.format_version != kSessionFormatVersion) {
      throw fail("format version " + std::to_string(m.format_version) + ", this build reads version " +
                 std::to_string(kSessionFormatVersion));
    }
    m.created_utc = root["created_utc"].as<std::string>();
    m.source = root["source"].as<std::string>();
    const YAML::Node camera = root["camera"];
    m.camera.width = camera["width"].as<int>();
    m.camera.height = camera["height"].as<int>();
    m.camera.fx = camera["fx"].as<double>();
    m.camera.fy = camera["fy"].as<double>();
    m.camera.cx = camera["cx"].as<double>();
    m.camera.cy = camera["cy"].as<double>();
    const std::vector<double> distortion = camera["distortion"].as<std::vector<double>>();
    if (distortion.size() != m.camera.distortion.size()) throw fail("camera distortion needs 5 numbers");
    std::copy(distortion.begin(), distortion.end(), m.camera.distortion.begin());
    m.num_keyframes = root["keyframes"].as<std::size_t>();
    m.num_map_points = root["map_points"].as<std::size_t>();
    m.num_gaussians = root["gaussians"].as<std::size_t>();
  } catch (const YAML::Exception& e) {
    throw fail(std::string("a field is missing or has the wrong type (") + e.what() + ")");
  }
  if (!m.camera.valid()) throw fail("invalid camera (focal lengths and image size must be > 0)");
  return m;
}

SessionManifest loadSession(SlamPipeline& pipeline, const std::string& dir, const CameraIntrinsics& run_camera) {
  const std::string manifest_path = join(dir, kSessionManifestFile);
  const SessionManifest m = readSessionManifest(manifest_path);
  const std::string mismatch = tracking::cameraMismatch(m.camera, run_camera);
  if (!mismatch.empty()) {
    throw std::runtime_error("session manifest '" + manifest_path + "': another camera than this run's: " + mismatch);
  }
  // Everything is read and checked before anything of the pipeline changes.
  const std::string tracker_path = join(dir, kSessionTrackerFile);
  tracking::TrackerSession session = tracking::loadTrackerSession(tracker_path, run_camera);
  if (session.map.keyframes.size() != m.num_keyframes || session.map.points.size() != m.num_map_points) {
    throw std::runtime_error("'" + tracker_path + "' holds " + std::to_string(session.map.keyframes.size()) +
                             " keyframes and " + std::to_string(session.map.points.size()) + " map points, '" +
                             manifest_path + "' says " + std::to_string(m.num_keyframes) + " and " +
                             std::to_string(m.num_map_points) + ": the files are not from one save");
  }
  if (pipeline.options().build_map) {
    const std::string map_path = join(dir, kSessionMapFile);
    const std::size_t in_file = plyVertexCount(map_path);
    if (in_file != m.num_gaussians) {
      throw std::runtime_error("'" + map_path + "' holds " + std::to_string(in_file) + " Gaussians, '" + manifest_path +
                               "' says " + std::to_string(m.num_gaussians) + ": the files are not from one save");
    }
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
