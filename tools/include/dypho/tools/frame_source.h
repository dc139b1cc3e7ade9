#pragma once
/// \file frame_source.h
/// One interface over the inputs `dypho_run_dataset` accepts: TUM-layout folders and bags.

#include <memory>
#include <string>
#include <vector>

#include "dypho/common/types.h"
#include "dypho/common/trajectory_io.h"

namespace dypho::tools {

/// A frame and, when the input has them (synthetic data), its ground-truth dynamic mask.
struct SourceFrame {
  RgbdFrame frame;
  cv::Mat mask;  ///< CV_8UC1, 255 = dynamic; empty when the input has no masks
};

/// Random-access RGB-D input.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual std::size_t size() const = 0;
  /// Throws std::runtime_error naming the file or message that cannot be read.
  virtual SourceFrame load(std::size_t i) const = 0;
  /// Ground truth poses (camera optical frame in the world); empty when none.
  virtual const std::vector<StampedPose>& groundtruth() const = 0;
  /// Camera name as in config/cameras (or the YAML path, or "camera_info" for bags).
  virtual std::string cameraName() const = 0;
  /// The camera file's rolling-shutter readout [ms]; 0 = global shutter or not known.
  virtual double rollingShutterReadoutMs() const { return 0.0; }
  virtual bool hasMasks() const = 0;
  /// For logs: what is being read.
  virtual std::string description() const = 0;
  /// Problems met while opening that did not stop it (e.g. malformed list lines skipped).
  virtual std::vector<std::string> warnings() const { return {}; }
};

/// Opens a TUM-layout folder or (when built with ROS) a .bag. `camera` = "" (detect from the
/// folder; bags use their camera_info), a name from config/cameras, or a YAML path. Throws
/// std::runtime_error with the fix when the input is missing, unreadable or the camera unknown.
std::unique_ptr<FrameSource> openFrameSource(const std::string& path, const std::string& camera,
                                             const std::string& config_dir);

/// Bag input; defined in frame_source_bag.cpp when built with ROS, else throws saying so.
std::unique_ptr<FrameSource> openBagFrameSource(const std::string& bag_path, const std::string& camera,
                                                const std::string& config_dir);

}  // namespace dypho::tools
