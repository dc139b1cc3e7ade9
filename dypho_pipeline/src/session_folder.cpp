/// The session folder: layout, manifest, and the halves the nodelets write and read apart.
#include "dypho/pipeline/session_folder.h"

#include <chrono>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include "dypho/common/atomic_file.h"

namespace dypho::pipeline {
namespace {

namespace fs = std::filesystem;

std::string utcNow() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::ostringstream os;
  os << std::put_time(&tm, "%Y-%m-%dT%H:%M:%SZ");
  return os.str();
}

/// A YAML double-quoted string (the source may hold any characters).
std::string yamlQuoted(const std::string& text) {
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

/// An exclusive lock on `dir`/.session.lock for this scope: the tracking and mapping nodelets
/// (threads of one manager or separate processes) complete a session one at a time.
class FolderLock {
 public:
  explicit FolderLock(const std::string& dir)
      : fd_(::open(sessionFile(dir, ".session.lock").c_str(), O_CREAT | O_RDWR, 0644)) {
    if (fd_ < 0) throw std::runtime_error("cannot create the lock file in '" + dir + "' (is it writable?)");
    ::flock(fd_, LOCK_EX);
  }
  ~FolderLock() {
    ::flock(fd_, LOCK_UN);
    ::close(fd_);
  }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_;
};

/// Whether `path` exists and was written at or after `since` (less a second of clock coarseness).
bool writtenSince(const std::string& path, fs::file_time_type since) {
  std::error_code ec;
  const fs::file_time_type written = fs::last_write_time(path, ec);
  return !ec && written >= since - std::chrono::seconds(1);
}

}  // namespace

std::string sessionFile(const std::string& dir, const char* name) { return (fs::path(dir) / name).string(); }

std::string resolveSessionDir(const std::string& path) {
  if (fs::is_regular_file(sessionFile(path, kSessionManifestFile))) return path;
  const std::string nested = sessionFolderIn(path);
  if (fs::is_regular_file(sessionFile(nested, kSessionManifestFile))) return nested;
  throw std::runtime_error("no session in '" + path + "': neither '" + sessionFile(path, kSessionManifestFile) +
                           "' nor '" + sessionFile(nested, kSessionManifestFile) +
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

void writeSessionManifest(const std::string& dir, SessionManifest m) {
  if (m.created_utc.empty()) m.created_utc = utcNow();
  writeFileAtomically(sessionFile(dir, kSessionManifestFile), [&](std::ostream& os) {
    os << std::setprecision(17);
    os << "# DyPho-SLAM session manifest (docs/file_formats.md), written after tracker.bin and map.ply\n"
       << "format_version: " << m.format_version << "\n"
       << "created_utc: " << yamlQuoted(m.created_utc) << "\n"
       << "source: " << yamlQuoted(m.source) << "\n"
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

void beginSessionSave(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw std::runtime_error("cannot create the session folder '" + dir + "'");
  const FolderLock lock(dir);
  fs::remove(sessionFile(dir, kSessionManifestFile), ec);
}

std::optional<SessionManifest> completeSession(const std::string& dir, fs::file_time_type since,
                                               const std::string& source, std::string* why) {
  const FolderLock lock(dir);
  const std::string tracker_path = sessionFile(dir, kSessionTrackerFile);
  const std::string map_path = sessionFile(dir, kSessionMapFile);
  for (const std::string& path : {tracker_path, map_path}) {
    if (writtenSince(path, since)) continue;
    if (why) *why = "'" + path + "' is missing or from an earlier save";
    return std::nullopt;
  }
  // Its own camera: this counts what the file holds (loading checks the run's camera).
  const tracking::TrackerSession session = tracking::loadTrackerSessionAnyCamera(tracker_path);
  SessionManifest m;
  m.camera = session.camera;
  m.num_keyframes = session.map.keyframes.size();
  m.num_map_points = session.map.points.size();
  m.num_gaussians = plyVertexCount(map_path);
  m.source = source;
  writeSessionManifest(dir, m);
  return m;
}

tracking::TrackerSession readSessionTracker(const std::string& dir, const SessionManifest& m,
                                            const CameraIntrinsics& run_camera) {
  const std::string manifest_path = sessionFile(dir, kSessionManifestFile);
  const std::string mismatch = tracking::cameraMismatch(m.camera, run_camera);
  if (!mismatch.empty()) {
    throw std::runtime_error("session manifest '" + manifest_path + "': another camera than this run's: " + mismatch);
  }
  const std::string tracker_path = sessionFile(dir, kSessionTrackerFile);
  tracking::TrackerSession session = tracking::loadTrackerSession(tracker_path, run_camera);
  if (session.map.keyframes.size() != m.num_keyframes || session.map.points.size() != m.num_map_points) {
    throw std::runtime_error("'" + tracker_path + "' holds " + std::to_string(session.map.keyframes.size()) +
                             " keyframes and " + std::to_string(session.map.points.size()) + " map points, '" +
                             manifest_path + "' says " + std::to_string(m.num_keyframes) + " and " +
                             std::to_string(m.num_map_points) + ": the files are not from one save");
  }
  return session;
}

std::string checkedSessionMap(const std::string& dir, const SessionManifest& m) {
  const std::string map_path = sessionFile(dir, kSessionMapFile);
  const std::size_t in_file = plyVertexCount(map_path);
  if (in_file != m.num_gaussians) {
    throw std::runtime_error("'" + map_path + "' holds " + std::to_string(in_file) + " Gaussians, '" +
                             sessionFile(dir, kSessionManifestFile) + "' says " + std::to_string(m.num_gaussians) +
                             ": the files are not from one save");
  }
  return map_path;
}

std::uint64_t sessionBytes(const std::string& dir) {
  std::uint64_t total = 0;
  for (const char* name : {kSessionTrackerFile, kSessionMapFile, kSessionManifestFile}) {
    std::error_code ec;
    const std::uintmax_t n = fs::file_size(sessionFile(dir, name), ec);
    if (!ec) total += static_cast<std::uint64_t>(n);
  }
  return total;
}

}  // namespace dypho::pipeline
