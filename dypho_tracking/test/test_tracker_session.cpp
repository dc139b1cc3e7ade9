/// The tracker session file (tracker_session.h) on a small session made by hand: lossless round
/// trip, the same bytes as the fuzz seed, and every kind of bad file refused with the caller's
/// state unchanged (cut short at every byte, any byte flipped, another version, another camera,
/// hostile counts, an inconsistent map behind a valid checksum). The session of a real run and
/// the resume are in test_tracker_session_resume.cpp.

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <iterator>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "dypho/tracking/rgbd_odometry.h"
#include "dypho/tracking/tracker_session.h"
#include "synthetic_scene.h"
#include "tracker_session_compare.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

namespace fs = std::filesystem;

/// Offsets in the file of a session with the layout of docs/file_formats.md.
constexpr std::size_t kVersionOffset = 8;
constexpr std::size_t kLengthOffset = 16;
constexpr std::size_t kChecksumOffset = 24;
constexpr std::size_t kKeyframeCountOffset = kTrackerSessionHeaderBytes + 80 + 5 * 8 + 2 * 96;
constexpr std::size_t kFirstFeatureCountOffset = kKeyframeCountOffset + 8 + 8 + 8 + 96 + 56;  // ... pose, blur
/// The map-point id of the first keyframe's first feature (the last field of a 112-byte feature).
constexpr std::size_t kFirstMapPointIdOffset = kFirstFeatureCountOffset + 8 + 112 - 8;

/// A rotation about y whose matrix entries are exact decimal literals (0.6, 0.8): the same bytes
/// on every machine.
Eigen::Isometry3d pose(double x, double y, double z, bool turned) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (turned) T.linear() << 0.6, 0.0, 0.8, 0.0, 1.0, 0.0, -0.8, 0.0, 0.6;
  T.translation() << x, y, z;
  return T;
}

MapKeyframe tinyKeyframe(std::int64_t id, const std::vector<std::int64_t>& map_point_ids) {
  MapKeyframe kf;
  kf.id = id;
  kf.stamp_ns = 1'700'000'000'000'000'000 + id * 33'333'333;
  kf.T_world_camera = pose(0.25 * static_cast<double>(id), -0.5, 1.0, id % 2 == 0);
  FrameFeatures& f = kf.features;
  const int n = static_cast<int>(map_point_ids.size());
  f.descriptors.create(n, 32, CV_8UC1);
  for (int i = 0; i < n; ++i) {
    const float u = 100.5f + 40.f * static_cast<float>(i) + static_cast<float>(id);
    f.keypoints.emplace_back(u, 200.25f - 10.f * static_cast<float>(i), 31.f, 12.5f * static_cast<float>(i),
                             0.001f * static_cast<float>(i + 1), i % 3, -1);
    f.uv_undistorted_px.emplace_back(u + 0.125, 200.0 - 10.0 * i);
    f.depth_m.push_back(1.5f + 0.25f * static_cast<float>(i));
    f.p_camera_m.emplace_back(0.1 * i, -0.2, 1.5 + 0.25 * i);
    for (int j = 0; j < 32; ++j) f.descriptors.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(37 * id + 11 * i + j);
  }
  kf.map_point_ids = map_point_ids;
  return kf;
}

MapPoint tinyPoint(std::int64_t id, std::map<std::int64_t, int> observations) {
  MapPoint p;
  p.id = id;
  p.p_world_m << 0.5 * static_cast<double>(id), 0.25, 2.0;
  p.descriptor.create(1, 32, CV_8UC1);
  for (int j = 0; j < 32; ++j) p.descriptor.at<std::uint8_t>(0, j) = static_cast<std::uint8_t>(200 + id + j);
  p.keypoint = cv::KeyPoint(50.f + static_cast<float>(id), 60.f, 31.f, 45.f, 0.5f, static_cast<int>(id % 4), -1);
  p.reference_distance_m = 1.75 + 0.125 * static_cast<double>(id);
  p.first_keyframe_id = observations.begin()->first;
  p.observations = std::move(observations);
  p.num_visible = 10 + static_cast<int>(id);
  p.num_found = 7 + static_cast<int>(id);
  p.num_on_dynamic = static_cast<int>(id % 2);
  p.num_on_dynamic_still = static_cast<int>(id % 3);
  p.num_confirmed = 3;
  p.num_refuted = static_cast<int>(id % 2);
  return p;
}

/// Two keyframes (0 and 2) of three features, keyframe 2 made in a fast turn (blurred), four map
/// points (point 4 was culled), keyframe 1 removed, a distorted camera, a loop and an unanchored
/// segment.
TrackerSession tinySession() {
  TrackerSession s;
  s.camera = test::testCamera();
  s.camera.distortion = {0.25, -0.125, 0.001953125, -0.0009765625, 0.0625};
  s.map.keyframes[0] = tinyKeyframe(0, {0, 1, -1});
  s.map.keyframes[2] = tinyKeyframe(2, {0, 2, 3});
  s.map.keyframes[2].blur_rates.omega_rad_s = Eigen::Vector3d(0.5, -2.0, 0.25);
  s.map.keyframes[2].blur_rates.velocity_m_s = Eigen::Vector3d(0.125, 0.0, -0.0625);
  s.map.keyframes[2].blur_exposure_s = 0.00390625;
  s.map.points[0] = tinyPoint(0, {{0, 0}, {2, 0}});
  s.map.points[1] = tinyPoint(1, {{0, 1}});
  s.map.points[2] = tinyPoint(2, {{2, 1}});
  s.map.points[3] = tinyPoint(3, {{2, 2}});
  s.map.removed[1] = RemovedKeyframe{0, pose(0.25, 0.0, 0.0, true)};
  s.map.next_point_id = 5;
  s.next_keyframe_id = 3;
  s.last_loop_keyframe_id = 2;
  s.unanchored_from_keyframe_id = -1;
  s.last_stamp_ns = 1'700'000'000'100'000'000;
  s.T_world_last = pose(0.75, -0.5, 1.25, true);
  s.T_world_odom = pose(0.0, 0.125, 0.0, false);
  for (std::int64_t id = 0; id < 3; ++id) s.reported_poses[id] = pose(0.25 * static_cast<double>(id), 0, 0, false);
  return s;
}

std::string tempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("dypho_session_" + std::to_string(::getpid()) + "_" + name)).string();
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void putU64(std::string* bytes, std::size_t offset, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) (*bytes)[offset + static_cast<std::size_t>(i)] = static_cast<char>((v >> (8 * i)) & 0xff);
}

/// The header's checksum recomputed after the payload was patched (so the checks behind it run).
void fixChecksum(std::string* bytes) {
  const std::size_t header = kTrackerSessionHeaderBytes;
  putU64(bytes, kChecksumOffset, trackerSessionChecksum(bytes->data() + header, bytes->size() - header));
}

/// The message of the std::runtime_error that loading `bytes` from a file throws ("" when none).
std::string loadError(const std::string& bytes, const CameraIntrinsics& camera = tinySession().camera) {
  const std::string path = tempPath("bad.bin");
  writeBytes(path, bytes);
  try {
    loadTrackerSession(path, camera);
  } catch (const std::runtime_error& e) {
    fs::remove(path);
    return e.what();
  }
  fs::remove(path);
  return "";
}

TEST(TrackerSession, SaveAndLoadKeepEveryField) {
  const TrackerSession session = tinySession();
  ASSERT_EQ(trackerSessionProblem(session), "");
  const std::string path = tempPath("tiny.bin");
  saveTrackerSession(path, session);
  const TrackerSession loaded = loadTrackerSession(path, session.camera);
  test::expectSameSession(session, loaded);
  // The same state gives the same bytes (id order, no padding, no clock).
  EXPECT_EQ(encodeTrackerSession(loaded), readBytes(path));
  EXPECT_FALSE(fs::exists(path + ".tmp." + std::to_string(::getpid()))) << "the temporary file was renamed";
  fs::remove(path);
}

// The fuzz seed (fuzz/corpus/tracker_session/tiny.bin) is this session's file. A change of the
// format shows here first: bump kTrackerSessionVersion, keep the old seed as the old version's
// file (tiny_v1.bin) while the loader reads that version, then rewrite the seed with
// DYPHO_WRITE_SESSION_SEED=1.
TEST(TrackerSession, TinySessionIsTheFuzzSeed) {
  const std::string seed = std::string(DYPHO_SOURCE_DIR) + "/fuzz/corpus/tracker_session/tiny.bin";
  const std::string bytes = encodeTrackerSession(tinySession());
  if (std::getenv("DYPHO_WRITE_SESSION_SEED") != nullptr) writeBytes(seed, bytes);
  const std::string seed_bytes = readBytes(seed);
  EXPECT_TRUE(seed_bytes == bytes) << seed << " (" << seed_bytes.size() << " bytes) is not the " << bytes.size()
                                   << "-byte file of this session: did the format change?";
}

// A file of format version 1 (the seed as the version-1 build wrote it; it has no keyframe blur)
// still loads: the same session with its keyframes sharp.
TEST(TrackerSession, VersionOneFileLoadsWithSharpKeyframes) {
  const std::string v1 = std::string(DYPHO_SOURCE_DIR) + "/fuzz/corpus/tracker_session/tiny_v1.bin";
  ASSERT_EQ(static_cast<unsigned char>(readBytes(v1)[kVersionOffset]), 1u) << v1;
  TrackerSession expected = tinySession();
  for (auto& [id, keyframe] : expected.map.keyframes) {
    keyframe.blur_rates = CameraRates();
    keyframe.blur_exposure_s = 0.0;
  }
  test::expectSameSession(expected, loadTrackerSession(v1, expected.camera));
}

TEST(TrackerSession, FileCutShortAnywhereIsRefusedAndChangesNothing) {
  const std::string bytes = encodeTrackerSession(tinySession());
  RgbdOdometry odometry{TrackingOptions()};
  odometry.restoreSession(tinySession());
  const std::string before = encodeTrackerSession(odometry.session());
  TrackerSession target = tinySession();
  const std::string path = tempPath("cut.bin");
  for (std::size_t cut = 0; cut < bytes.size(); ++cut) {
    writeBytes(path, bytes.substr(0, cut));
    try {
      target = loadTrackerSession(path, target.camera);
      odometry.restoreSession(target);
      ADD_FAILURE() << "a file cut at byte " << cut << " of " << bytes.size() << " was loaded";
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(path), std::string::npos) << message;
      EXPECT_NE(message.find(cut == 0 ? "empty" : "truncated"), std::string::npos) << "cut " << cut << ": " << message;
    }
  }
  fs::remove(path);
  EXPECT_EQ(encodeTrackerSession(target), bytes);
  EXPECT_EQ(encodeTrackerSession(odometry.session()), before);
}

TEST(TrackerSession, LongerFileIsRefused) {
  const std::string message = loadError(encodeTrackerSession(tinySession()) + '\0');
  EXPECT_NE(message.find("1 bytes more than the header announces"), std::string::npos) << message;
}

TEST(TrackerSession, AnyFlippedByteIsRefused) {
  const std::string bytes = encodeTrackerSession(tinySession());
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    std::string flipped = bytes;
    flipped[i] = static_cast<char>(flipped[i] ^ 0x10);
    const std::string message = loadError(flipped);
    EXPECT_FALSE(message.empty()) << "byte " << i << " flipped, the file was loaded";
    if (i >= kTrackerSessionHeaderBytes || (i >= kChecksumOffset && i < kChecksumOffset + 8)) {
      EXPECT_NE(message.find("checksum mismatch"), std::string::npos) << "byte " << i << ": " << message;
    }
  }
  EXPECT_NE(loadError("PLY" + bytes.substr(3)).find("not a DyPho-SLAM tracker session"), std::string::npos);
}

TEST(TrackerSession, OtherFormatVersionIsRefused) {
  for (int version : {0, 3, 255}) {
    std::string bytes = encodeTrackerSession(tinySession());
    bytes[kVersionOffset] = static_cast<char>(version);
    const std::string message = loadError(bytes);
    EXPECT_NE(message.find("format version " + std::to_string(version) + ", this build reads versions 1 to 2"),
              std::string::npos)
        << message;
  }
}

TEST(TrackerSession, OtherCameraIsRefused) {
  const std::string bytes = encodeTrackerSession(tinySession());
  const CameraIntrinsics camera = tinySession().camera;
  EXPECT_EQ(loadError(bytes, camera), "");
  CameraIntrinsics close = camera;
  close.fx *= 1 + 5e-7;
  close.distortion[2] += 5e-7;  // under 1e-6 of max(1, |p1|)
  EXPECT_EQ(loadError(bytes, close), "") << "within 1e-6 relative: the same camera";
  auto refused = [&](CameraIntrinsics other, const std::string& what) {
    const std::string message = loadError(bytes, other);
    EXPECT_NE(message.find("the session is for another camera"), std::string::npos) << what << ": " << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
  };
  CameraIntrinsics other = camera;
  other.fx *= 1 + 2e-6;
  refused(other, "fx");
  other = camera;
  other.cy += 0.5;
  refused(other, "cy");
  other = camera;
  other.width = 1280;
  refused(other, "image size 640x480 in the session, 1280x480 in this run");
  other = camera;
  other.distortion = {0, 0, 0, 0, 0};
  refused(other, "k1");
}

TEST(TrackerSession, HostileCountsAreRefusedBeforeAllocating) {
  for (std::size_t offset : {kKeyframeCountOffset, kFirstFeatureCountOffset}) {
    std::string bytes = encodeTrackerSession(tinySession());
    putU64(&bytes, offset, std::uint64_t{1} << 61);
    fixChecksum(&bytes);
    const std::string message = loadError(bytes);
    EXPECT_NE(message.find("2305843009213693952 "), std::string::npos) << message;
    EXPECT_NE(message.find("do not fit in the"), std::string::npos) << message;
  }
}

TEST(TrackerSession, InconsistentMapBehindAValidChecksumIsRefused) {
  std::string bytes = encodeTrackerSession(tinySession());
  putU64(&bytes, kFirstMapPointIdOffset, static_cast<std::uint64_t>(std::int64_t{-5}));
  fixChecksum(&bytes);
  const std::string message = loadError(bytes);
  EXPECT_NE(message.find("keyframe 0: map-point id -5 is outside [-1, 5)"), std::string::npos) << message;
  bytes = encodeTrackerSession(tinySession());
  putU64(&bytes, kLengthOffset, bytes.size());  // the header's own length is no payload
  EXPECT_NE(loadError(bytes).find("truncated"), std::string::npos);
}

TEST(TrackerSession, InconsistentSessionIsNeitherSavedNorRestored) {
  RgbdOdometry odometry{TrackingOptions()};
  odometry.restoreSession(tinySession());
  const std::string before = encodeTrackerSession(odometry.session());
  auto refused = [&](const TrackerSession& bad, const std::string& what) {
    EXPECT_NE(trackerSessionProblem(bad).find(what), std::string::npos) << trackerSessionProblem(bad);
    EXPECT_THROW(encodeTrackerSession(bad), std::invalid_argument) << what;
    EXPECT_THROW(odometry.restoreSession(bad), std::invalid_argument) << what;
  };
  TrackerSession bad = tinySession();
  bad.map.points[2].observations[2] = 3;  // keyframe 2 has features 0-2
  refused(bad, "map point 2: observed as feature 3 of keyframe 2, which has 3");
  bad = tinySession();
  bad.map.points[3].observations[7] = 0;
  refused(bad, "map point 3: observed by unknown keyframe 7");
  bad = tinySession();
  bad.next_keyframe_id = 2;  // new keyframes would take id 2 again
  refused(bad, "keyframe id 2 is not below the next keyframe id 2");
  bad = tinySession();
  bad.map.next_point_id = 3;
  refused(bad, "is outside [-1, 3)");
  bad = tinySession();
  bad.map.keyframes[0].T_world_camera.matrix()(0, 0) = 2.0;
  refused(bad, "keyframe 0: its pose is not a rigid transform");
  bad = tinySession();
  bad.map.keyframes[2].blur_exposure_s = -0.004;
  refused(bad, "keyframe 2: its motion blur is not finite");
  bad = tinySession();
  bad.map.keyframes[2].blur_rates.omega_rad_s.y() = std::numeric_limits<double>::quiet_NaN();
  refused(bad, "keyframe 2: its motion blur is not finite");
  bad = tinySession();
  bad.map.keyframes[2].features.depth_m.pop_back();
  refused(bad, "keyframe 2: its feature arrays differ in length");
  bad = tinySession();
  bad.map.keyframes.clear();
  refused(bad, "no keyframe");
  EXPECT_EQ(encodeTrackerSession(odometry.session()), before) << "a refused session changed the tracker";
}

TEST(TrackerSession, RestoredTrackerContinuesTheIds) {
  RgbdOdometry odometry{TrackingOptions()};
  EXPECT_THROW(odometry.session(), std::logic_error) << "no keyframe yet";
  odometry.restoreSession(tinySession());
  test::expectSameSession(odometry.session(), tinySession());
  EXPECT_EQ(odometry.map().nextPointId(), 5);
  // The removed keyframe still answers through its parent.
  const std::optional<Eigen::Isometry3d> removed = odometry.map().keyframePose(1);
  ASSERT_TRUE(removed.has_value());
  EXPECT_TRUE(removed->isApprox(pose(0.0, -0.5, 1.0, true) * pose(0.25, 0.0, 0.0, true), 1e-15));
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
