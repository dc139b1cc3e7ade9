#pragma once
/// \file tracker_session_codec.h
/// The payload of a tracker session file as little-endian fixed-size fields (internal to
/// dypho_tracking_core; the framing, checks and file access are in tracker_session.cpp).

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "dypho/tracking/tracker_session.h"

namespace dypho {
namespace tracking {

/// Appends little-endian fixed-size fields to a byte string.
class ByteWriter {
 public:
  void reserve(std::size_t bytes) { out_.reserve(bytes); }
  void raw(const void* data, std::size_t size) { out_.append(static_cast<const char*>(data), size); }
  void u32(std::uint32_t v) { appendLittleEndian(v, 4); }
  void u64(std::uint64_t v) { appendLittleEndian(v, 8); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void f32(float v);
  void f64(double v);
  /// Overwrites the 8 bytes at `offset` with `v` (a header field known only at the end).
  void patchU64(std::size_t offset, std::uint64_t v);
  /// The bytes written so far.
  std::string& bytes() { return out_; }

 private:
  void appendLittleEndian(std::uint64_t v, int bytes);
  std::string out_;
};

/// Reads little-endian fixed-size fields from a byte range; throws std::runtime_error (what ran
/// out, how many bytes were left) instead of reading past its end.
class ByteReader {
 public:
  ByteReader(const char* data, std::size_t size) : data_(reinterpret_cast<const unsigned char*>(data)), size_(size) {}
  std::uint32_t u32() { return static_cast<std::uint32_t>(readLittleEndian(4)); }
  std::uint64_t u64() { return readLittleEndian(8); }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  std::int64_t i64() { return static_cast<std::int64_t>(u64()); }
  float f32();
  double f64();
  /// Copies the next `size` bytes to `out`.
  void raw(void* out, std::size_t size);
  /// A u64 count of records of at least `record_bytes` each; throws when the bytes left cannot
  /// hold that many (before the caller allocates anything for them).
  std::size_t count(std::size_t record_bytes, const char* what);
  /// As count, for a u32 count.
  std::size_t count32(std::size_t record_bytes, const char* what);
  std::size_t remaining() const { return size_ - pos_; }

 private:
  std::uint64_t readLittleEndian(int bytes);
  const unsigned char* take(std::size_t size);
  std::size_t checkedCount(std::uint64_t n, std::size_t record_bytes, const char* what) const;
  const unsigned char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

/// Appends the payload of `session` (see docs/file_formats.md) to `out`.
void encodeSessionPayload(const TrackerSession& session, ByteWriter* out);

/// The session in a payload of format `version` (kTrackerSessionOldestVersion to
/// kTrackerSessionVersion); throws std::runtime_error saying what is wrong (a count larger than
/// the bytes left, ids out of order, bytes left over). Its content is not checked further here
/// (trackerSessionProblem).
TrackerSession decodeSessionPayload(const char* data, std::size_t size, std::uint32_t version);

}  // namespace tracking
}  // namespace dypho
