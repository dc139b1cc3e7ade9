#pragma once
/// \file training_frames.h
/// A file of RGB-D training frames for mapping_bench_cuda --frames: the posed frames of a real
/// sequence at training resolution, written by export_training_frames (which reads the dataset
/// with OpenCV) and read here without OpenCV, so that GPU machines without OpenCV train on them.
///
/// Layout (little-endian): "DYPHOTF1", uint32 count, int32 width, int32 height, 4 x float64
/// fx fy cx cy, then per frame: 16 x float64 T_world_camera (row-major 4x4), 3 x W x H float32
/// RGB in [0, 1] (planar), W x H float32 depth [m] (0 = invalid).

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace dypho::bench {

struct TrainingFrame {
  double T_world_camera[16];   ///< row-major 4x4
  std::vector<float> rgb;      ///< [3, H, W]
  std::vector<float> depth_m;  ///< [H, W]
};

struct TrainingFrames {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<TrainingFrame> frames;
};

inline TrainingFrames readTrainingFrames(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw std::runtime_error("cannot open training frames file '" + path + "'");
  struct Closer {
    std::FILE* f;
    ~Closer() { std::fclose(f); }
  } closer{f};
  auto read = [&](void* dst, std::size_t bytes) {
    if (std::fread(dst, 1, bytes, f) != bytes) throw std::runtime_error("'" + path + "' is truncated");
  };
  char magic[8];
  read(magic, 8);
  if (std::memcmp(magic, "DYPHOTF1", 8) != 0) throw std::runtime_error("'" + path + "' is not a training frames file");
  std::uint32_t count = 0;
  TrainingFrames t;
  read(&count, 4);
  read(&t.width, 4);
  read(&t.height, 4);
  double k[4];
  read(k, sizeof(k));
  t.fx = k[0];
  t.fy = k[1];
  t.cx = k[2];
  t.cy = k[3];
  if (t.width <= 0 || t.height <= 0 || t.width > 8192 || t.height > 8192 || count > 100000 || !(t.fx > 0) ||
      !(t.fy > 0)) {
    throw std::runtime_error("'" + path + "' has an implausible header");
  }
  const std::size_t npix = static_cast<std::size_t>(t.width) * t.height;
  t.frames.resize(count);
  for (TrainingFrame& fr : t.frames) {
    read(fr.T_world_camera, sizeof(fr.T_world_camera));
    fr.rgb.resize(3 * npix);
    fr.depth_m.resize(npix);
    read(fr.rgb.data(), fr.rgb.size() * sizeof(float));
    read(fr.depth_m.data(), fr.depth_m.size() * sizeof(float));
  }
  return t;
}

/// Writes `t` to `path` atomically (a temporary beside it, renamed when complete).
inline void writeTrainingFrames(const std::string& path, const TrainingFrames& t) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) throw std::runtime_error("cannot write '" + tmp + "'");
  bool ok = true;
  auto write = [&](const void* src, std::size_t bytes) { ok = ok && std::fwrite(src, 1, bytes, f) == bytes; };
  write("DYPHOTF1", 8);
  const std::uint32_t count = static_cast<std::uint32_t>(t.frames.size());
  write(&count, 4);
  write(&t.width, 4);
  write(&t.height, 4);
  const double k[4] = {t.fx, t.fy, t.cx, t.cy};
  write(k, sizeof(k));
  for (const TrainingFrame& fr : t.frames) {
    write(fr.T_world_camera, sizeof(fr.T_world_camera));
    write(fr.rgb.data(), fr.rgb.size() * sizeof(float));
    write(fr.depth_m.data(), fr.depth_m.size() * sizeof(float));
  }
  ok = (std::fclose(f) == 0) && ok;
  if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error("writing '" + path + "' failed");
  }
}

}  // namespace dypho::bench
