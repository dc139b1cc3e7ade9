/// The tracker session file: header (magic, version, payload length, checksum), the checks of a
/// session, and the file access (tracker_session.h).
#include "dypho/tracking/tracker_session.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "dypho/common/atomic_file.h"
#include "tracker_session_codec.h"

namespace dypho {
namespace tracking {
namespace {

constexpr char kMagic[8] = {'D', 'Y', 'P', 'H', 'O', 'T', 'R', 'K'};
constexpr std::size_t kLengthOffset = 16;    // u64 payload length in the header
constexpr std::size_t kChecksumOffset = 24;  // u64 FNV-1a 64 of the payload

std::string hex(std::uint64_t v) {
  std::ostringstream os;
  os << "0x" << std::hex << std::setw(16) << std::setfill('0') << v;
  return os.str();
}

/// First reason the ids outside the map (counters, loop and segment markers, reported poses)
/// cannot go on from `s`; empty when they can.
std::string trackerIdProblem(const TrackerSession& s) {
  const std::int64_t next = s.next_keyframe_id;
  std::int64_t newest = s.map.keyframes.rbegin()->first;
  if (!s.map.removed.empty()) newest = std::max(newest, s.map.removed.rbegin()->first);
  if (!s.reported_poses.empty()) newest = std::max(newest, s.reported_poses.rbegin()->first);
  if (newest >= next) {
    return "keyframe id " + std::to_string(newest) + " is not below the next keyframe id " + std::to_string(next);
  }
  for (std::int64_t id : {s.last_loop_keyframe_id, s.unanchored_from_keyframe_id}) {
    if (id < -1 || id >= next)
      return "keyframe id " + std::to_string(id) + " outside [-1, " + std::to_string(next) + ")";
  }
  if (!s.reported_poses.empty() && s.reported_poses.begin()->first < 0) return "a reported keyframe id is negative";
  return "";
}

std::string posesProblem(const TrackerSession& s) {
  if (!isRigidPose(s.T_world_last) || !isRigidPose(s.T_world_odom)) {
    return "the last pose or the loop correction is not a rigid transform";
  }
  for (const auto& [id, T] : s.reported_poses) {
    if (!isRigidPose(T)) return "the reported pose of keyframe " + std::to_string(id) + " is not a rigid transform";
  }
  return "";
}

bool finiteCamera(const CameraIntrinsics& c) {
  return std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy) &&
         std::all_of(c.distortion.begin(), c.distortion.end(), [](double d) { return std::isfinite(d); });
}

/// The checks of the header in `bytes` (magic, size, version, length, checksum); throws the
/// problem without the file name. Returns the format version.
std::uint32_t checkHeader(const std::string& bytes) {
  if (bytes.empty()) throw std::runtime_error("the file is empty");
  if (std::memcmp(bytes.data(), kMagic, std::min(bytes.size(), sizeof kMagic)) != 0) {
    throw std::runtime_error("not a DyPho-SLAM tracker session (it does not start with 'DYPHOTRK')");
  }
  if (bytes.size() < kTrackerSessionHeaderBytes) {
    throw std::runtime_error("truncated: " + std::to_string(bytes.size()) + " bytes, the header alone has " +
                             std::to_string(kTrackerSessionHeaderBytes));
  }
  ByteReader header(bytes.data() + sizeof kMagic, kTrackerSessionHeaderBytes - sizeof kMagic);
  const std::uint32_t version = header.u32();
  if (version < kTrackerSessionOldestVersion || version > kTrackerSessionVersion) {
    throw std::runtime_error("format version " + std::to_string(version) + ", this build reads versions " +
                             std::to_string(kTrackerSessionOldestVersion) + " to " +
                             std::to_string(kTrackerSessionVersion) + " only (saved by another DyPho-SLAM version?)");
  }
  if (const std::uint32_t reserved = header.u32(); reserved != 0) {
    throw std::runtime_error("reserved header field is " + std::to_string(reserved) + ", not 0");
  }
  const std::uint64_t length = header.u64(), checksum = header.u64();
  const std::size_t have = bytes.size() - kTrackerSessionHeaderBytes;
  if (length > have) {
    throw std::runtime_error("truncated: the header announces " + std::to_string(length) +
                             " payload bytes, the file has " + std::to_string(have));
  }
  if (length < have) {
    throw std::runtime_error(std::to_string(have - length) + " bytes more than the header announces (" +
                             std::to_string(length) + " payload bytes)");
  }
  const std::uint64_t actual = trackerSessionChecksum(bytes.data() + kTrackerSessionHeaderBytes, have);
  if (actual != checksum) {
    throw std::runtime_error("checksum mismatch, the file is corrupt (payload FNV-1a 64 " + hex(actual) +
                             ", the header says " + hex(checksum) + ")");
  }
  return version;
}

}  // namespace

std::uint64_t trackerSessionChecksum(const char* data, std::size_t size) {
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a 64 offset basis
  for (std::size_t i = 0; i < size; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ull;  // FNV 64 prime
  }
  return h;
}

std::string trackerSessionProblem(const TrackerSession& s) {
  if (!s.camera.valid() || !finiteCamera(s.camera)) {
    return "the camera is not valid (finite numbers, positive focal lengths and image size)";
  }
  if (s.map.keyframes.empty()) return "it has no keyframe (nothing to go on from)";
  std::string problem = trackerMapStateProblem(s.map);
  if (problem.empty()) problem = trackerIdProblem(s);
  if (problem.empty()) problem = posesProblem(s);
  return problem;
}

std::string cameraMismatch(const CameraIntrinsics& session_camera, const CameraIntrinsics& run_camera) {
  std::ostringstream os;
  os << std::setprecision(12);
  const char* separator = "";
  if (session_camera.width != run_camera.width || session_camera.height != run_camera.height) {
    os << "image size " << session_camera.width << "x" << session_camera.height << " in the session, "
       << run_camera.width << "x" << run_camera.height << " in this run";
    separator = "; ";
  }
  auto compare = [&](const char* name, double a, double b, double floor) {
    if (std::abs(a - b) <= 1e-6 * std::max({floor, std::abs(a), std::abs(b)})) return;
    os << separator << name << " " << a << " in the session, " << b << " in this run";
    separator = "; ";
  };
  compare("fx", session_camera.fx, run_camera.fx, 0.0);
  compare("fy", session_camera.fy, run_camera.fy, 0.0);
  compare("cx", session_camera.cx, run_camera.cx, 0.0);
  compare("cy", session_camera.cy, run_camera.cy, 0.0);
  const char* names[5] = {"k1", "k2", "p1", "p2", "k3"};
  for (std::size_t i = 0; i < 5; ++i) {
    compare(names[i], session_camera.distortion[i], run_camera.distortion[i], 1.0);
  }
  return os.str();
}

std::string encodeTrackerSession(const TrackerSession& session) {
  const std::string problem = trackerSessionProblem(session);
  if (!problem.empty()) throw std::invalid_argument("cannot save the tracker session: " + problem);
  ByteWriter w;
  w.raw(kMagic, sizeof kMagic);
  w.u32(kTrackerSessionVersion);
  w.u32(0);  // reserved
  w.u64(0);  // payload length, patched below
  w.u64(0);  // checksum, patched below
  encodeSessionPayload(session, &w);
  std::string& bytes = w.bytes();
  const std::size_t length = bytes.size() - kTrackerSessionHeaderBytes;
  w.patchU64(kLengthOffset, length);
  w.patchU64(kChecksumOffset, trackerSessionChecksum(bytes.data() + kTrackerSessionHeaderBytes, length));
  return std::move(bytes);
}

namespace {

/// decodeTrackerSession, checking the camera only when `run_camera` is given.
TrackerSession decode(const std::string& bytes, const CameraIntrinsics* run_camera, const std::string& source) {
  auto fail = [&](const std::string& what) { return std::runtime_error("cannot load '" + source + "': " + what); };
  TrackerSession session;
  try {
    const std::uint32_t version = checkHeader(bytes);
    session = decodeSessionPayload(bytes.data() + kTrackerSessionHeaderBytes, bytes.size() - kTrackerSessionHeaderBytes,
                                   version);
  } catch (const std::runtime_error& e) {
    throw fail(e.what());
  }
  const std::string problem = trackerSessionProblem(session);
  if (!problem.empty()) throw fail(problem);
  if (run_camera == nullptr) return session;
  const std::string mismatch = cameraMismatch(session.camera, *run_camera);
  if (!mismatch.empty()) throw fail("the session is for another camera (" + mismatch + ")");
  return session;
}

std::string readSessionBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw std::runtime_error("cannot load '" + path + "': cannot open it (does it exist, is it readable?)");
  const std::streamoff size = in.tellg();
  in.seekg(0);
  if (size < 0 || !in) throw std::runtime_error("cannot load '" + path + "': cannot read it (not a regular file?)");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  if (!in.read(bytes.data(), size)) throw std::runtime_error("cannot load '" + path + "': read error");
  return bytes;
}

}  // namespace

TrackerSession decodeTrackerSession(const std::string& bytes, const CameraIntrinsics& run_camera,
                                    const std::string& source) {
  return decode(bytes, &run_camera, source);
}

void saveTrackerSession(const std::string& path, const TrackerSession& session) {
  const std::string bytes = encodeTrackerSession(session);
  writeFileAtomically(
      path, [&](std::ostream& out) { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); },
      /*binary=*/true);
}

TrackerSession loadTrackerSession(const std::string& path, const CameraIntrinsics& run_camera) {
  return decode(readSessionBytes(path), &run_camera, path);
}

TrackerSession loadTrackerSessionAnyCamera(const std::string& path) {
  return decode(readSessionBytes(path), nullptr, path);
}

}  // namespace tracking
}  // namespace dypho
