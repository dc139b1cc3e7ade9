#pragma once
/// \file synthetic_writer.h
/// Writes a SyntheticScene to disk in the TUM RGB-D folder layout (plus ground-truth masks).

#include <functional>
#include <string>

#include "dypho/tools/synthetic_scene.h"

namespace dypho::tools {

/// Settings of writeSyntheticDataset().
struct SynthWriteOptions {
  /// Command line recorded in README.txt (how the folder was generated); empty = not recorded.
  std::string command_line;
  /// Called once per frame after its PNGs are written, in frame order (e.g. to also write a bag
  /// with BagRgbdWriter from dypho_bag, which keeps this library ROS-free). May throw to abort.
  std::function<void(const SynthFrame&)> on_frame;
  /// Called after each frame with (frames done, total) for progress output.
  std::function<void(int, int)> on_progress;
};

/// What writeSyntheticDataset() produced.
struct SynthWriteSummary {
  int frames = 0;                    ///< frames written
  double mean_dynamic_fraction = 0;  ///< mean share of pixels covered by people (mask == 255)
  double max_dynamic_fraction = 0;   ///< largest per-frame share of people pixels
  double path_length_m = 0;          ///< camera path length [m]
  double duration_s = 0;             ///< time of the last frame minus the first [s]
};

/// Renders `options.frames` frames into `out_dir` (created if missing):
///   rgb/<stamp>.png   8-bit colour;  depth/<stamp>.png 16-bit, metres * 5000 (0 = no depth);
///   mask/<stamp>.png  8-bit, 255 = person (dynamic), 0 = static;
///   rgb.txt, depth.txt, mask.txt ("timestamp path"), groundtruth.txt (TUM
///   "timestamp tx ty tz qx qy qz qw", camera optical frame in the world), camera.yaml (name:
///   synthetic), README.txt (content, options, command line).
/// <stamp> is "%.6f" seconds. Every file is written to a temporary name and renamed, and the text
/// files are written after all images, so an interrupted run never leaves a half-written file
/// or a list naming a missing image. Throws std::runtime_error on invalid options or I/O errors.
SynthWriteSummary writeSyntheticDataset(const SynthOptions& options, const std::string& out_dir,
                                        const SynthWriteOptions& write_options = {});

/// The camera YAML text (keys name, width, height, fx, fy, cx, cy, distortion, depth_scale, and
/// rolling_shutter_readout_ms when it is > 0 [ms]) that writeSyntheticDataset() stores as camera.yaml.
std::string synthCameraYaml(const CameraIntrinsics& camera, double depth_scale = 5000.0,
                            double rolling_shutter_readout_ms = 0.0);

}  // namespace dypho::tools
