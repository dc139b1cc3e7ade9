#pragma once
/// \file slam_pipeline.h
/// The three cores (mask, tracking, mapping) chained in one process, without ROS: what the
/// nodelets do over topics, done in a loop. Used by `dypho_run_dataset` and the dataset tests.

#include <optional>
#include <string>

#include "dypho/mapping/gaussian_mapper.h"
#include "dypho/mapping/keyframe_cloud_map.h"
#include "dypho/mask/dynamic_masker.h"
#include "dypho/tracking/rgbd_odometry.h"

namespace dypho::tools {

/// Where the dynamic mask of each frame comes from.
enum class MaskSource {
  kFlow,      ///< the mask core (default, what the ROS graph does)
  kExternal,  ///< given by the caller (e.g. ground-truth masks of a synthetic sequence)
  kNone,      ///< no mask: every pixel static
};

/// Parses "flow", "external"/"gt", "none"; throws listing the valid names.
MaskSource parseMaskSource(const std::string& name);

/// All settings of the in-process pipeline.
struct PipelineOptions {
  mask::DynamicMaskOptions mask;         ///< mask core (config/mask.yaml)
  tracking::TrackingOptions tracking;    ///< tracking core (config/tracking.yaml)
  mapping::MappingOptions mapping;       ///< mapping cores: point cloud + Gaussian map (config/mapping.yaml)
  MaskSource mask_source = MaskSource::kFlow;  ///< where masks come from
};

/// Loads `<config_dir>/{mask,tracking,mapping}.yaml`, then applies `override_yaml` (a file with
/// optional top-level maps `mask:`, `tracking:`, `mapping:`) when not empty. Missing keys keep
/// the built-in defaults; unknown keys and bad values throw std::runtime_error naming the file.
PipelineOptions loadPipelineOptions(const std::string& config_dir, const std::string& override_yaml);

/// Writes the effective options as one YAML document with `mask:`, `tracking:`, `mapping:` maps
/// (usable as `--config`).
void writePipelineOptionsYaml(std::ostream& out, PipelineOptions options);

/// What happened to one frame.
struct FrameReport {
  tracking::TrackingResult tracking;  ///< pose, state, keyframe, tracking stage times
  double mask_ms = 0.0;               ///< time of the mask core [ms]
  double mapping_ms = 0.0;            ///< time spent adding a keyframe to the map [ms] (0 otherwise)
  double masked_fraction = 0.0;       ///< share of the image the mask excluded [0, 1]
  bool mask_degraded = false;         ///< the mask core could not trust its mask this frame
};

/// Runs mask -> tracking -> mapping on each frame, in order. Not thread-safe.
class SlamPipeline {
 public:
  explicit SlamPipeline(const PipelineOptions& options);

  /// Processes one frame. `external_mask` (CV_8UC1, 255 = dynamic) is used only with
  /// MaskSource::kExternal; an empty one means "all static".
  FrameReport process(const RgbdFrame& frame, const cv::Mat& external_mask = cv::Mat());

  /// The map built so far.
  const mapping::KeyframeCloudMap& map() const { return map_; }

  /// The tracker (its keyframes' current poses give the final trajectory, TrajectoryRecorder).
  const tracking::RgbdOdometry& odometry() const { return odometry_; }

  /// The 3D Gaussian map. Keyframes are optimised on its worker thread (iterations_per_keyframe
  /// each, in order; process() waits only when 4 keyframes are already queued), so results do not
  /// depend on timing. Every call is thread-safe, e.g. `gaussianMap().renderDepth(T, camera)`.
  mapping::GaussianMapper& gaussianMap() const { return *gaussian_map_; }
  /// Waits until the Gaussian map has integrated and optimised every keyframe handed to it, then
  /// runs its final refinement (`final_refine_iterations`, GaussianMapper::finish()).
  void finishMapping() { gaussian_map_->finish(); }

 private:
  PipelineOptions options_;
  /// Mask prior of the next frame: constant-velocity T_prev_cur from the last two tracked poses,
  /// rendered depth from `renderPredictedDepth`.
  mask::MaskPrior predictMaskPrior(const RgbdFrame& frame) const;
  /// MASK HOOK for mapping: depth rendered from the map at `T_world_camera_pred` (CV_32FC1 [m],
  /// the frame's size). Returns empty (no render yet) until the mapping core offers a renderer.
  cv::Mat renderPredictedDepth(const RgbdFrame& frame, const Eigen::Isometry3d& T_world_camera_pred) const;

  mask::DynamicMasker masker_;
  /// Last two trusted camera poses (world), newest last, for the constant-velocity prediction.
  std::optional<Eigen::Isometry3d> T_world_prev_;
  std::optional<Eigen::Isometry3d> T_world_prevprev_;
  tracking::RgbdOdometry odometry_;
  mapping::KeyframeCloudMap map_;
  std::unique_ptr<mapping::GaussianMapper> gaussian_map_;  ///< started in the constructor
};

}  // namespace dypho::tools
