#pragma once
/// \file pipeline_options.h
/// Settings of the in-process pipeline: the three modules' options (config/*.yaml) and the
/// stages' policies.

#include <ostream>
#include <string>

#include "dypho/mapping/gaussian_mapper_options.h"
#include "dypho/mapping/mapping_stage.h"
#include "dypho/mask/dynamic_mask_options.h"
#include "dypho/mask/mask_stage.h"
#include "dypho/tracking/mask_pairing.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho::pipeline {

/// Where the dynamic mask of each frame comes from.
enum class MaskSource {
  kFlow,      ///< the mask stage (default, what the ROS graph does)
  kExternal,  ///< given by the caller (e.g. ground-truth masks of a synthetic sequence)
  kNone,      ///< no mask: every pixel static
};

/// Parses "flow", "external"/"gt", "none"; throws listing the valid names.
MaskSource parseMaskSource(const std::string& name);

/// All settings of the in-process pipeline.
struct PipelineOptions {
  mask::DynamicMaskOptions mask;               ///< mask core (config/mask.yaml)
  tracking::TrackingOptions tracking;          ///< tracking core (config/tracking.yaml)
  mapping::MappingOptions mapping;             ///< mapping cores: point cloud + Gaussian map (config/mapping.yaml)
  MaskSource mask_source = MaskSource::kFlow;  ///< where masks come from
  mask::MaskStageOptions mask_stage;           ///< R_d hand-over and motion prior of the mask stage
  mapping::MappingStageOptions mapping_stage;  ///< queue of the mapping stage
  /// false: the mapping stage gets no poses, corrections or keyframes, so no map is built (mask
  /// and tracking only: trajectory benchmarks). R_d then has no map to render and the mask runs
  /// without it. Default true.
  bool build_map = true;
  /// Live runs only (RealtimeRunner): how tracking pairs each frame with its mask, the tracking
  /// nodelet's ~mask_max_wait_s, ~mask_max_pending_frames, ~mask_max_carry_age_s with their
  /// defaults (0.1 s, 30 frames, 0.2 s; mask_pairing.h).
  tracking::MaskPairingOptions mask_pairing;
  /// Deterministic runs only (SlamPipeline::process): the mask stage gets each frame's pose (and
  /// moving points) only after it has masked the next frame, as the live graph's mask does
  /// whenever tracking takes longer than MaskStageOptions::previous_pose_wait_s or frames wait
  /// behind it. Every mask then starts from a prediction made from older poses
  /// (MaskPrior::prediction_fresh false): a repeatable stand-in for the live graph's stale
  /// predictions, for benchmarks (dypho_run_dataset --late-mask-poses). The stage's wait is off
  /// with it (the pose could never arrive in time). Default false.
  bool mask_poses_one_frame_late = false;
};

/// Loads `<config_dir>/{mask,tracking,mapping}.yaml`, then applies `override_yaml` (a file with
/// optional top-level maps `mask:`, `tracking:`, `mapping:`) when not empty. Missing keys keep
/// the built-in defaults; unknown keys and bad values throw std::runtime_error naming the file.
PipelineOptions loadPipelineOptions(const std::string& config_dir, const std::string& override_yaml);

/// Writes the effective options as one YAML document with `mask:`, `tracking:`, `mapping:` maps
/// (usable as `--config`).
void writePipelineOptionsYaml(std::ostream& out, PipelineOptions options);

}  // namespace dypho::pipeline
