/// The payload of a tracker session file: each record as little-endian fixed-size fields, in the
/// order docs/file_formats.md lists them.
#include "tracker_session_codec.h"

#include <climits>
#include <cstring>
#include <limits>
#include <utility>

namespace dypho {
namespace tracking {
namespace {

static_assert(std::numeric_limits<float>::is_iec559 && std::numeric_limits<double>::is_iec559,
              "the session format stores IEEE 754 floats");

constexpr std::size_t kPoseBytes = 12 * 8;             // 3x4 matrix, f64, row-major
constexpr std::size_t kKeypointBytes = 5 * 4 + 2 * 4;  // x y size angle response, octave class_id
constexpr std::size_t kDescriptorBytes = 32;           // ORB
constexpr std::size_t kFeatureBytes = kKeypointBytes + 2 * 8 + 4 + 3 * 8 + kDescriptorBytes + 8;
constexpr std::size_t kBlurBytes = 7 * 8;                          // omega, velocity, exposure (version 2)
constexpr std::size_t kKeyframeMinBytes = 8 + 8 + kPoseBytes + 8;  // id, stamp, pose, feature count (+ blur)
constexpr std::size_t kObservationBytes = 8 + 4;                   // keyframe id, feature index
constexpr std::size_t kPointMinBytes = 8 + 3 * 8 + kDescriptorBytes + kKeypointBytes + 8 + 8 + 6 * 4 + 4;
constexpr std::size_t kRemovedBytes = 8 + 8 + kPoseBytes;  // id, parent id, pose
constexpr std::size_t kReportedBytes = 8 + kPoseBytes;     // id, pose

void putPose(const Eigen::Isometry3d& T, ByteWriter* w) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) w->f64(T.matrix()(r, c));
}

Eigen::Isometry3d getPose(ByteReader* r) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int row = 0; row < 3; ++row)
    for (int c = 0; c < 4; ++c) T.matrix()(row, c) = r->f64();
  return T;
}

void putKeypoint(const cv::KeyPoint& k, ByteWriter* w) {
  w->f32(k.pt.x);
  w->f32(k.pt.y);
  w->f32(k.size);
  w->f32(k.angle);
  w->f32(k.response);
  w->i32(k.octave);
  w->i32(k.class_id);
}

cv::KeyPoint getKeypoint(ByteReader* r) {
  cv::KeyPoint k;
  k.pt.x = r->f32();
  k.pt.y = r->f32();
  k.size = r->f32();
  k.angle = r->f32();
  k.response = r->f32();
  k.octave = r->i32();
  k.class_id = r->i32();
  return k;
}

void putCamera(const CameraIntrinsics& c, ByteWriter* w) {
  w->f64(c.fx);
  w->f64(c.fy);
  w->f64(c.cx);
  w->f64(c.cy);
  w->i32(c.width);
  w->i32(c.height);
  for (double d : c.distortion) w->f64(d);
}

CameraIntrinsics getCamera(ByteReader* r) {
  CameraIntrinsics c;
  c.fx = r->f64();
  c.fy = r->f64();
  c.cx = r->f64();
  c.cy = r->f64();
  c.width = r->i32();
  c.height = r->i32();
  for (double& d : c.distortion) d = r->f64();
  return c;
}

/// Row `row` of `descriptors` (32 bytes; trackerSessionProblem checked the shape before).
void putDescriptor(const cv::Mat& descriptors, int row, ByteWriter* w) {
  w->raw(descriptors.ptr<std::uint8_t>(row), kDescriptorBytes);
}

void putKeyframe(const MapKeyframe& kf, ByteWriter* w) {
  w->i64(kf.id);
  w->i64(kf.stamp_ns);
  putPose(kf.T_world_camera, w);
  for (int k = 0; k < 3; ++k) w->f64(kf.blur_rates.omega_rad_s[k]);
  for (int k = 0; k < 3; ++k) w->f64(kf.blur_rates.velocity_m_s[k]);
  w->f64(kf.blur_exposure_s);
  const FrameFeatures& f = kf.features;
  w->u64(f.size());
  for (std::size_t i = 0; i < f.size(); ++i) {
    putKeypoint(f.keypoints[i], w);
    w->f64(f.uv_undistorted_px[i].x());
    w->f64(f.uv_undistorted_px[i].y());
    w->f32(f.depth_m[i]);
    for (int k = 0; k < 3; ++k) w->f64(f.p_camera_m[i][k]);
    putDescriptor(f.descriptors, static_cast<int>(i), w);
    w->i64(kf.map_point_ids[i]);
  }
}

MapKeyframe getKeyframe(ByteReader* r, std::uint32_t version) {
  MapKeyframe kf;
  kf.id = r->i64();
  kf.stamp_ns = r->i64();
  kf.T_world_camera = getPose(r);
  if (version >= 2) {
    for (int k = 0; k < 3; ++k) kf.blur_rates.omega_rad_s[k] = r->f64();
    for (int k = 0; k < 3; ++k) kf.blur_rates.velocity_m_s[k] = r->f64();
    kf.blur_exposure_s = r->f64();
  }
  const std::size_t n = r->count(kFeatureBytes, "features");
  FrameFeatures& f = kf.features;
  f.keypoints.resize(n);
  f.uv_undistorted_px.resize(n);
  f.depth_m.resize(n);
  f.p_camera_m.resize(n);
  kf.map_point_ids.resize(n);
  if (n > 0) f.descriptors.create(static_cast<int>(n), static_cast<int>(kDescriptorBytes), CV_8UC1);
  for (std::size_t i = 0; i < n; ++i) {
    f.keypoints[i] = getKeypoint(r);
    f.uv_undistorted_px[i].x() = r->f64();
    f.uv_undistorted_px[i].y() = r->f64();
    f.depth_m[i] = r->f32();
    for (int k = 0; k < 3; ++k) f.p_camera_m[i][k] = r->f64();
    r->raw(f.descriptors.ptr<std::uint8_t>(static_cast<int>(i)), kDescriptorBytes);
    kf.map_point_ids[i] = r->i64();
  }
  return kf;
}

void putPoint(const MapPoint& p, ByteWriter* w) {
  w->i64(p.id);
  for (int k = 0; k < 3; ++k) w->f64(p.p_world_m[k]);
  putDescriptor(p.descriptor, 0, w);
  putKeypoint(p.keypoint, w);
  w->f64(p.reference_distance_m);
  w->i64(p.first_keyframe_id);
  for (int counter :
       {p.num_visible, p.num_found, p.num_on_dynamic, p.num_on_dynamic_still, p.num_confirmed, p.num_refuted}) {
    w->i32(counter);
  }
  w->u32(static_cast<std::uint32_t>(p.observations.size()));
  for (const auto& [keyframe_id, index] : p.observations) {
    w->i64(keyframe_id);
    w->i32(index);
  }
}

MapPoint getPoint(ByteReader* r) {
  MapPoint p;
  p.id = r->i64();
  for (int k = 0; k < 3; ++k) p.p_world_m[k] = r->f64();
  p.descriptor.create(1, static_cast<int>(kDescriptorBytes), CV_8UC1);
  r->raw(p.descriptor.ptr<std::uint8_t>(0), kDescriptorBytes);
  p.keypoint = getKeypoint(r);
  p.reference_distance_m = r->f64();
  p.first_keyframe_id = r->i64();
  for (int* counter :
       {&p.num_visible, &p.num_found, &p.num_on_dynamic, &p.num_on_dynamic_still, &p.num_confirmed, &p.num_refuted}) {
    *counter = r->i32();
  }
  const std::size_t n = r->count32(kObservationBytes, "observations");
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t keyframe_id = r->i64();
    const int index = r->i32();
    if (!p.observations.emplace(keyframe_id, index).second) {
      throw std::runtime_error("map point " + std::to_string(p.id) + " lists keyframe " + std::to_string(keyframe_id) +
                               " twice");
    }
  }
  return p;
}

/// Adds `value` under `id` to `records`; ids must increase through the file (so no id repeats).
template <typename Map, typename Value>
void insertInOrder(std::int64_t id, Value&& value, const char* what, Map* records) {
  if (!records->empty() && id <= records->rbegin()->first) {
    throw std::runtime_error(std::string(what) + " ids out of order: " + std::to_string(id) + " after " +
                             std::to_string(records->rbegin()->first));
  }
  records->emplace_hint(records->end(), id, std::forward<Value>(value));
}

/// A first guess of the payload size, so the bytes are not copied while they grow.
std::size_t payloadSizeEstimate(const TrackerSession& s) {
  std::size_t bytes = 512 + s.map.removed.size() * kRemovedBytes + s.reported_poses.size() * kReportedBytes;
  for (const auto& [id, kf] : s.map.keyframes) {
    bytes += kKeyframeMinBytes + kBlurBytes + kf.features.size() * kFeatureBytes;
  }
  for (const auto& [id, p] : s.map.points) bytes += kPointMinBytes + p.observations.size() * kObservationBytes;
  return bytes;
}

void putTrackerFields(const TrackerSession& s, ByteWriter* w) {
  putCamera(s.camera, w);
  w->i64(s.next_keyframe_id);
  w->i64(s.map.next_point_id);
  w->i64(s.last_loop_keyframe_id);
  w->i64(s.unanchored_from_keyframe_id);
  w->i64(s.last_stamp_ns);
  putPose(s.T_world_last, w);
  putPose(s.T_world_odom, w);
}

void getTrackerFields(ByteReader* r, TrackerSession* s) {
  s->camera = getCamera(r);
  s->next_keyframe_id = r->i64();
  s->map.next_point_id = r->i64();
  s->last_loop_keyframe_id = r->i64();
  s->unanchored_from_keyframe_id = r->i64();
  s->last_stamp_ns = r->i64();
  s->T_world_last = getPose(r);
  s->T_world_odom = getPose(r);
}

}  // namespace

void ByteWriter::appendLittleEndian(std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out_.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
}

void ByteWriter::f32(float v) {
  std::uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  u32(bits);
}

void ByteWriter::f64(double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  u64(bits);
}

void ByteWriter::patchU64(std::size_t offset, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out_.at(offset + static_cast<std::size_t>(i)) = static_cast<char>((v >> (8 * i)) & 0xffu);
}

const unsigned char* ByteReader::take(std::size_t size) {
  if (size > remaining()) {
    throw std::runtime_error("the payload ends inside a record (" + std::to_string(size) + " bytes needed, " +
                             std::to_string(remaining()) + " left)");
  }
  const unsigned char* p = data_ + pos_;
  pos_ += size;
  return p;
}

std::uint64_t ByteReader::readLittleEndian(int bytes) {
  const unsigned char* p = take(static_cast<std::size_t>(bytes));
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}

float ByteReader::f32() {
  const std::uint32_t bits = u32();
  float v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

double ByteReader::f64() {
  const std::uint64_t bits = u64();
  double v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

void ByteReader::raw(void* out, std::size_t size) { std::memcpy(out, take(size), size); }

std::size_t ByteReader::checkedCount(std::uint64_t n, std::size_t record_bytes, const char* what) const {
  // Division, not multiplication: a hostile count cannot overflow past the check.
  if (n > remaining() / record_bytes || n > static_cast<std::uint64_t>(INT_MAX)) {
    throw std::runtime_error(std::to_string(n) + " " + what + " of at least " + std::to_string(record_bytes) +
                             " bytes each do not fit in the " + std::to_string(remaining()) + " bytes left");
  }
  return static_cast<std::size_t>(n);
}

std::size_t ByteReader::count(std::size_t record_bytes, const char* what) {
  return checkedCount(u64(), record_bytes, what);
}

std::size_t ByteReader::count32(std::size_t record_bytes, const char* what) {
  return checkedCount(u32(), record_bytes, what);
}

void encodeSessionPayload(const TrackerSession& s, ByteWriter* w) {
  w->reserve(w->bytes().size() + payloadSizeEstimate(s));
  putTrackerFields(s, w);
  w->u64(s.map.keyframes.size());
  for (const auto& [id, kf] : s.map.keyframes) putKeyframe(kf, w);
  w->u64(s.map.points.size());
  for (const auto& [id, p] : s.map.points) putPoint(p, w);
  w->u64(s.map.removed.size());
  for (const auto& [id, removed] : s.map.removed) {
    w->i64(id);
    w->i64(removed.parent_id);
    putPose(removed.T_parent_keyframe, w);
  }
  w->u64(s.reported_poses.size());
  for (const auto& [id, T] : s.reported_poses) {
    w->i64(id);
    putPose(T, w);
  }
}

TrackerSession decodeSessionPayload(const char* data, std::size_t size, std::uint32_t version) {
  ByteReader r(data, size);
  TrackerSession s;
  getTrackerFields(&r, &s);
  const std::size_t keyframe_min_bytes = kKeyframeMinBytes + (version >= 2 ? kBlurBytes : 0);
  for (std::size_t n = r.count(keyframe_min_bytes, "keyframes"), i = 0; i < n; ++i) {
    MapKeyframe kf = getKeyframe(&r, version);
    insertInOrder(kf.id, std::move(kf), "keyframe", &s.map.keyframes);
  }
  for (std::size_t n = r.count(kPointMinBytes, "map points"), i = 0; i < n; ++i) {
    MapPoint p = getPoint(&r);
    insertInOrder(p.id, std::move(p), "map point", &s.map.points);
  }
  for (std::size_t n = r.count(kRemovedBytes, "removed keyframes"), i = 0; i < n; ++i) {
    const std::int64_t id = r.i64();
    RemovedKeyframe removed;
    removed.parent_id = r.i64();
    removed.T_parent_keyframe = getPose(&r);
    insertInOrder(id, removed, "removed keyframe", &s.map.removed);
  }
  for (std::size_t n = r.count(kReportedBytes, "reported poses"), i = 0; i < n; ++i) {
    const std::int64_t id = r.i64();
    insertInOrder(id, getPose(&r), "reported keyframe", &s.reported_poses);
  }
  if (r.remaining() != 0) {
    throw std::runtime_error(std::to_string(r.remaining()) + " bytes after the last record of the payload");
  }
  return s;
}

}  // namespace tracking
}  // namespace dypho
