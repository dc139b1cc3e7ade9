#pragma once
/// \file mapping_stage.h
/// The mapping module's stage: the Gaussian map (GaussianMapper) and the keyframe point cloud plus
/// the policy around them, shared by the in-process pipeline and GaussianMappingNodelet (which
/// only converts and publishes).
///
/// Policy, in one place:
///  - Keyframes and correction batches go to the mapper's worker in arrival order (MappingWorker).
///    kDeterministic (offline runner): a full queue blocks the producer; kLive (ROS graph): a
///    full queue merges the new job into the newest waiting one (counted); nothing is dropped.
///  - R_d, the depth the mask's background model B_i blends in: rendered from a snapshot of the
///    map (never under the map's lock, so training is not held up) at the constant-velocity
///    prediction of the frame's pose (motion_prior.h, fed with tracked poses), through the mask's
///    working camera. Which snapshot: kDeterministic uses the map as it stood after the job of the
///    keyframe *before* the newest one (waited for when the newest is added), so a run is
///    bit-for-bit repeatable while the worker trains one keyframe ahead; kLive uses the newest.
///  - Tracking restarted (stamp went backwards): both maps are cleared (observePose).
///  - Final refinement (`final_refine_iterations` over all keyframes): finish(), called by
///    whoever saves the final map (the runner at the end, the nodelet's save_map and shutdown).
/// Thread-safe.

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/motion_prior.h"
#include "dypho/common/types.h"
#include "dypho/mapping/gaussian_mapper.h"
#include "dypho/mapping/keyframe_cloud_map.h"
#include "dypho/mapping/map_renderer.h"

namespace dypho::mapping {

/// How the stage trades timing for repeatability (see the file comment).
enum class MappingMode { kDeterministic, kLive };

/// Settings of the stage's policy (not of the mapping algorithms).
struct MappingStageOptions {
  /// Jobs (keyframes, correction batches) waiting for the worker [count]; default 8, >= 1.
  int keyframe_queue_size = 8;
  /// Poses further apart than this give no velocity for the R_d prediction [s]; default 1.0.
  double motion_max_gap_s = 1.0;
};

/// Counters of the stage.
struct MappingStageStats {
  GaussianMapperStats gaussians;               ///< the mapper's counters
  std::size_t keyframes_received = 0;          ///< keyframes handed to the stage
  std::size_t correction_batches = 0;          ///< correction batches handed to the stage
  std::size_t predicted_depth_rendered = 0;    ///< R_d images rendered
  std::int64_t render_snapshot_keyframe = -1;  ///< keyframe of the snapshot R_d is rendered from
};

class MappingStage {
 public:
  /// Validates the options (std::invalid_argument) and starts the mapper's worker.
  MappingStage(const MappingOptions& options, MappingMode mode, const MappingStageOptions& stage = {});
  ~MappingStage();  ///< stops the worker

  /// A new keyframe: into the point cloud and onto the worker's queue. Returns false when the
  /// live policy merged it into a waiting job (mapping is behind; the keyframe is still seeded).
  bool addKeyframe(KeyframeConstPtr keyframe);
  /// Keyframe poses changed by local BA or loop closure: point cloud now, Gaussians in order on
  /// the worker.
  void correctKeyframes(const KeyframePoseCorrections& corrections);
  /// The tracked pose of a frame, for the R_d prediction. A restart (PoseUpdate::restarted)
  /// clears both maps first.
  void observePose(const PoseUpdate& update);
  /// Stamp of the next frame, expected one frame interval after the last pose (the graph renders
  /// R_d ahead of the frame); empty without a velocity.
  std::optional<Timestamp> expectedNextStamp() const;
  /// R_d for the frame stamped `stamp_ns`, through `camera` (MaskStage::workingCamera): CV_32FC1
  /// [m]. Empty when the pose cannot be predicted or there is no map yet.
  cv::Mat predictedDepth(Timestamp stamp_ns, const CameraIntrinsics& camera);
  /// R_d for the next frame, rendered ahead of it (the graph: the mask needs it when that frame
  /// arrives): predictedDepth(expectedNextStamp(), camera) with that stamp; empty depth when
  /// there is no velocity or no map.
  std::pair<Timestamp, cv::Mat> predictedDepthForNextFrame(const CameraIntrinsics& camera);
  /// The newest snapshot rendered at `T_world_camera` (rviz views). Empty view when no map yet.
  RenderedView renderView(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera);

  /// Waits for the worker, then runs the final refinement unless it already ran for the current
  /// keyframes; returns its mean loss (0 when skipped).
  /// `budget_s`: bounded in wall time, see GaussianMapper::finish.
  double finish(std::optional<double> budget_s = std::nullopt);
  /// finish(), then map.ply (3DGS), map.pcd (keyframe cloud) and gaussian_centres.pcd in `dir`,
  /// each atomically; returns the paths. `refine` = false skips finish().
  std::vector<std::string> save(const std::string& dir, bool refine = true,
                                std::optional<double> budget_s = std::nullopt);
  /// The evaluation file's name in an output folder.
  static constexpr const char* kEvaluationFile = "map_evaluation.txt";
  /// map_evaluation.txt in `dir`: the map's quality at the stored keyframes, as the offline
  /// runner reports it (PSNR on static pixels, depth L1), and the keyframes received, in the map
  /// and merged jobs, written atomically; returns the quality. With `budget_s`, no keyframe is
  /// started after that wall time (GaussianMapper::evaluateKeyframes).
  KeyframeEvaluation writeEvaluation(const std::string& dir, std::optional<double> budget_s = std::nullopt);
  /// Replaces the Gaussian map with a 3DGS PLY (GaussianMapper::loadPly); returns the count.
  std::size_t loadMap(const std::string& path, std::string* note = nullptr);
  /// Clears both maps and the motion prior.
  void reset();

  MappingStageStats stats() const;
  /// The coloured keyframe cloud (voxel filtered). Built outside the cloud's lock from a snapshot,
  /// so a slow build (every keyframe's points through the voxel filter) never holds up
  /// addKeyframe() or correctKeyframes().
  KeyframeCloudMap::Cloud::Ptr buildCloud() const;
  /// Centres of the live map (waits for the running training iteration).
  std::vector<GaussianCentre> gaussianCentres() const { return gaussians_.centres(); }
  /// Centres of the latest snapshot (after a keyframe's job, or about once a second of idle
  /// training): never waits for training, for publishers on ROS callback threads. Empty (no
  /// value) before the first snapshot of a world.
  std::optional<std::vector<GaussianCentre>> latestGaussianCentres() const;
  /// The Gaussian mapper (evaluation, direct queries).
  GaussianMapper& gaussians() { return gaussians_; }
  const GaussianMapper& gaussians() const { return gaussians_; }
  std::size_t numCloudPoints() const;
  MappingMode mode() const { return mode_; }

 private:
  MappingMode mode_;
  MappingStageOptions stage_options_;
  GaussianMapper gaussians_;

  /// Guards cloud_ alone (taken only briefly: buildCloud() builds from a snapshot outside it).
  mutable std::mutex cloud_mutex_;
  KeyframeCloudMap cloud_;
  mutable std::mutex mutex_;  ///< guards everything below
  ConstantVelocityModel motion_;
  std::int64_t newest_keyframe_id_ = -1;
  MapSnapshot render_snapshot_;                ///< kDeterministic: the map R_d is rendered from
  std::int64_t refined_after_keyframes_ = -1;  ///< keyframes_received when finish() last refined
  MappingStageStats counters_;

  /// R_d (predictedDepth) and the views for viewers (renderView) each have a renderer of their
  /// own: the views' thread runs at the training's nice value, and a view render holding a shared
  /// renderer would keep the mask waiting for R_d behind it.
  std::mutex depth_render_mutex_;  ///< one R_d render at a time
  MapRenderer depth_renderer_;
  std::mutex view_render_mutex_;  ///< one view render at a time
  MapRenderer view_renderer_;
};

}  // namespace dypho::mapping
