/// libFuzzer target: the tracker session loader (session/tracker.bin from anywhere: cut short,
/// corrupt, hostile counts, an inconsistent map). Each input is read twice: as the file it is
/// (magic, version, length and checksum checks), and with its length and checksum made right, so
/// that mutations reach the payload decoder and the map checks behind the checksum. Errors must
/// be std::runtime_error, never a crash, a sanitizer report or a huge allocation.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "dypho/tracking/tracker_session.h"
#include "fuzz_input.h"

namespace {

/// The camera of the seed (fuzz/corpus/tracker_session/tiny.bin, see test_tracker_session.cpp).
dypho::CameraIntrinsics seedCamera() {
  dypho::CameraIntrinsics c;
  c.fx = c.fy = 525.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  c.distortion = {0.25, -0.125, 0.001953125, -0.0009765625, 0.0625};
  return c;
}

/// `bytes` with the header's payload length and checksum set to match its payload.
std::string withValidChecksum(std::string bytes) {
  const std::size_t header = dypho::tracking::kTrackerSessionHeaderBytes;
  if (bytes.size() < header) return bytes;
  const std::uint64_t length = bytes.size() - header;
  const std::uint64_t checksum = dypho::tracking::trackerSessionChecksum(bytes.data() + header, length);
  for (int i = 0; i < 8; ++i) {
    bytes[16 + static_cast<std::size_t>(i)] = static_cast<char>((length >> (8 * i)) & 0xff);
    bytes[24 + static_cast<std::size_t>(i)] = static_cast<char>((checksum >> (8 * i)) & 0xff);
  }
  return bytes;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const dypho::CameraIntrinsics camera = seedCamera();
  const std::string path = dypho::fuzz::writeInput(data, size, ".bin");
  try {
    dypho::tracking::loadTrackerSession(path, camera);
  } catch (const std::runtime_error&) {
  }
  try {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    dypho::tracking::decodeTrackerSession(withValidChecksum(bytes), camera, "fuzz input");
  } catch (const std::runtime_error&) {
  }
  return 0;
}
