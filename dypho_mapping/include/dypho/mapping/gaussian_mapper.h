#pragma once
/// \file gaussian_mapper.h
/// The incremental 3D Gaussian Splatting map of the paper: keyframes in (seeded at their feature
/// points and at unexplained static pixels), optimised on a sliding window with Adam on the loss
/// (1 - lambda) |Mc (Cr - C)|_1 + lambda |M (Dr - D)|_1 (M: static pixels with valid depth),
/// densified and pruned; renders colour and depth at any pose.
///
/// Cameras: keyframes with plumb_bob distortion are undistorted once per camera
/// (cv::initUndistortRectifyMap onto the pinhole with the same fx fy cx cy); the map is trained
/// and rendered in that pinhole camera. `render()`/`renderDepth()` map the result back into the
/// distorted image of the requested camera, so their output lines up with the input images.
///
/// Jobs, each in its own file: GaussianTrainer (seeding, iterations, re-anchoring; private),
/// MappingWorker (thread + ordered job queue), MapRenderer (renders, also of snapshots outside the
/// lock), keyframe_evaluation.h, gaussian_map_io.h (PLY/PCD). This class composes them.
///
/// Threads: every public function is thread-safe (one mutex guards the trainer; stats() reads
/// counters refreshed after each change and never waits for an iteration). With `start()`,
/// the worker takes jobs in order: a keyframe is seeded and trained on for
/// `iterations_per_keyframe` iterations, then the map is copied into a snapshot tagged with that
/// keyframe's id; a correction batch re-anchors its keyframes. Results do not depend on timing
/// (the backward pass reduces in a fixed order). The lock is released between iterations, so a
/// render waits at most one iteration; renders of a snapshot (MapRenderer) wait for nothing.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/gaussian_map_io.h"
#include "dypho/mapping/gaussian_mapper_options.h"
#include "dypho/mapping/keyframe_evaluation.h"
#include "dypho/mapping/map_renderer.h"
#include "dypho/mapping/mapping_worker.h"

namespace dypho::mapping {

struct GaussianTrainer;

/// Result of integrating one keyframe.
struct AddKeyframeResult {
  bool added = false;             ///< false: skipped, `message` says why
  std::size_t new_gaussians = 0;  ///< Gaussians seeded
  bool capacity_reached = false;  ///< seeding stopped at max_gaussians
  std::string message;            ///< why it was skipped / what was capped
};

/// Counters of the mapper.
struct GaussianMapperStats {
  std::size_t num_gaussians = 0;      ///< Gaussians in the map
  std::size_t num_keyframes = 0;      ///< keyframes integrated (poses kept)
  std::size_t num_stored_images = 0;  ///< keyframes whose images are kept
  std::int64_t iterations = 0;        ///< optimisation iterations run
  std::size_t queued = 0;             ///< jobs waiting for the worker
  /// Jobs merged into a waiting one because the queue was full (live policy: mapping is behind;
  /// every keyframe is still seeded, only training is shared out).
  std::size_t merged_jobs = 0;
  std::size_t skipped_keyframes = 0;    ///< rejected (bad pose, no depth, ...)
  std::size_t capacity_hits = 0;        ///< times seeding or densification stopped at the cap
  std::size_t corrected_keyframes = 0;  ///< keyframe re-anchorings applied (local BA, loop closure)
  double last_loss = 0.0;               ///< loss of the last iteration
};

/// A copy of the map as it stood after a keyframe's job (integration and its iterations).
struct MapSnapshot {
  std::shared_ptr<const GaussianMap> map;  ///< null before the first keyframe's job finished
  std::int64_t after_keyframe_id = -1;     ///< the keyframe whose job it follows
  std::int64_t iterations = 0;             ///< optimisation iterations run by then
};

class GaussianMapper {
 public:
  /// Validates `options` (std::invalid_argument).
  explicit GaussianMapper(const GaussianMapperOptions& options);
  ~GaussianMapper();  ///< stops the worker (pending jobs are discarded)
  GaussianMapper(const GaussianMapper&) = delete;
  GaussianMapper& operator=(const GaussianMapper&) = delete;

  // --- synchronous use (tests, tools) ------------------------------------------------------
  /// Seeds keyframe `keyframe` into the map (no optimisation). Keyframes with a non-finite or
  /// non-rigid pose, empty/mismatched images, invalid intrinsics or no valid static depth are
  /// skipped with a message (never throws for bad data). A known id re-anchors that keyframe.
  AddKeyframeResult addKeyframe(const Keyframe& keyframe);
  /// Runs `iterations` optimisation iterations on the window; returns the mean loss (0 when the
  /// map or the window is empty).
  double optimize(int iterations);

  // --- worker thread -----------------------------------------------------------------------
  /// Starts the worker with a queue of `queue_capacity` jobs (no-op when running). `live`: the
  /// live policy (ROS graph): a keyframe's training stops after live_min_iterations_per_keyframe
  /// iterations when the next job waits, and with live_train_when_idle the worker trains while
  /// no job waits (fewer iterations when busy, more when idle; the queue never grows).
  void start(std::size_t queue_capacity, bool live = false);
  /// Hands a keyframe to the worker (MappingWorker's policy: with `block_when_full` waits for
  /// room, otherwise merges it into the newest waiting job and returns false; it is never
  /// dropped). Without a running worker, integrates and optimises synchronously.
  bool enqueueKeyframe(KeyframeConstPtr keyframe, bool block_when_full);
  /// Hands a batch of keyframe pose corrections to the worker, after the jobs already queued
  /// (never dropped). Without a running worker, applies it at once.
  void enqueueCorrections(KeyframePoseCorrections corrections, bool block_when_full);
  /// Waits until the queue is empty and the worker has finished its iterations.
  void waitUntilIdle();
  /// End of a sequence: waitUntilIdle(), then `final_refine_iterations` iterations over all stored
  /// keyframes (shuffled passes, each keyframe equally often) on the calling thread. Call it once
  /// before the final map is saved or evaluated. Returns the mean loss of those iterations (0: none).
  /// With `budget_s` (shutdown, where the process has seconds): the queued keyframes are added to
  /// the map (seeded, corrections applied) without their training iterations, and refinement
  /// stops once `budget_s` [s] have passed since the call. With exposure_mean_gauge, the map's
  /// colours then move into the keyframes' mean exposure.
  double finish(std::optional<double> budget_s = std::nullopt);
  /// Stops and joins the worker (remaining queued jobs are discarded).
  void stop();
  /// Receives one line per skipped keyframe or notable event from the worker (optional).
  void setMessageSink(std::function<void(const std::string&)> sink);

  // --- snapshots (the map to render from without taking the lock) ---------------------------
  /// The newest snapshot (map null before the first keyframe's job finished).
  MapSnapshot latestSnapshot() const;
  /// Waits until the job of keyframe `keyframe_id` (or a later one) has finished and returns the
  /// newest snapshot; returns at once when the worker is not running.
  MapSnapshot waitForSnapshot(std::int64_t keyframe_id) const;

  // --- queries (thread-safe) -----------------------------------------------------------------
  /// Re-anchors the Gaussians seeded from keyframe `id` after a pose correction; false when the
  /// id is unknown or the pose is not finite/rigid.
  bool updateKeyframePose(std::int64_t id, const Eigen::Isometry3d& T_world_camera);
  /// Colour, depth and alpha seen from `T_world_camera` through `camera` (MapRenderer::render on
  /// the live map, under the lock). Throws std::invalid_argument for invalid intrinsics or a
  /// non-finite pose.
  RenderedView render(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const;
  /// Depth only (CV_32FC1 [m], 0 = nothing rendered), same geometry as render().
  cv::Mat renderDepth(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const;
  /// PSNR on static pixels and depth L1 at the stored keyframes. When `side_by_side_dir` is not
  /// empty, writes `kf_<id>.png` there (input | rendered colour (after the keyframe's exposure)
  /// over input depth | rendered depth). With `budget_s`, no keyframe is started after that wall
  /// time (keyframes taken in an order spread over the run).
  KeyframeEvaluation evaluateKeyframes(const std::string& side_by_side_dir = "",
                                       std::optional<double> budget_s = std::nullopt) const;
  /// Centres and DC colours of all Gaussians.
  std::vector<GaussianCentre> centres() const;
  /// Writes the map as a 3DGS PLY, atomically. Throws std::runtime_error naming the path.
  void savePly(const std::string& path) const;
  /// Replaces the map with a 3DGS PLY (Gaussians not anchored to keyframes). Throws
  /// std::runtime_error naming the problem (missing, not binary little-endian, truncated, missing
  /// properties); the current map is kept then. Beyond max_gaussians the rest is dropped, and SH
  /// degrees other than sh_degree are truncated or zero-padded: `note` (optional) says so. The file
  /// is read before the map lock is taken, so the worker and renders wait only for the swap.
  std::size_t loadPly(const std::string& path, std::string* note = nullptr);
  /// Writes the centres as a binary PCD (x y z rgb), atomically.
  void saveCentresPcd(const std::string& path) const;
  GaussianMapperStats stats() const;
  /// Poses of the integrated keyframes (after any corrections), in insertion order.
  KeyframePoseCorrections keyframePoses() const;
  /// Removes every Gaussian and keyframe (the worker keeps running; waiting jobs are discarded).
  void reset();
  const GaussianMapperOptions& options() const { return options_; }
  /// Where training and the renders run (options().device resolved at construction).
  ComputeDevice computeDevice() const { return device_; }
  /// One line saying which device was chosen and, for a fallback, why (to be logged once).
  const std::string& deviceMessage() const { return device_message_; }

 private:
  /// Runs one job on the worker thread.
  void runJob(const MappingJob& job);
  /// Applies a correction batch under the lock; returns the keyframes moved.
  std::size_t applyCorrections(const KeyframePoseCorrections& corrections);
  void publishSnapshot(std::int64_t keyframe_id);
  void report(const std::string& message) const;
  /// Live policy, worker thread: one training iteration while no job waits; false when there is
  /// nothing to train (no keyframe yet, or finish() runs).
  bool idleStep();
  /// Live policy, worker thread: one training iteration, then the rest that
  /// live_cpu_training_duty asks for (CPU device only). Returns the iteration's loss (< 0: none).
  double liveIteration();

  GaussianMapperOptions options_;
  std::unique_ptr<GaussianTrainer> trainer_;  ///< guarded by mutex_
  /// Reports (once) that training left the GPU after a CUDA failure; call under mutex_.
  void reportDeviceFallback();

  ComputeDevice device_ = ComputeDevice::kCpu;
  std::string device_message_;
  bool fallback_reported_ = false;
  mutable std::unique_ptr<MapRenderer> renderer_;  ///< renders of the live map, guarded by mutex_
  mutable std::mutex mutex_;
  std::size_t corrected_ = 0;  ///< guarded by mutex_
  /// mutex_ for a change to the trainer (defined in the .cpp): refreshes stats_ on release.
  class ChangeLock;
  /// Copies the trainer's counters into stats_; call under mutex_.
  void refreshStats() const;
  /// The counters as they stood after the last change, guarded by stats_mutex_ (never held
  /// during an iteration): stats() is called from ROS timer threads and must not wait for training.
  mutable std::mutex stats_mutex_;
  mutable GaussianMapperStats stats_;

  std::unique_ptr<MappingWorker> worker_;
  std::function<void(const std::string&)> sink_;

  mutable std::mutex snapshot_mutex_;
  mutable std::condition_variable snapshot_cv_;
  MapSnapshot snapshot_;
  std::int64_t done_keyframe_id_ = -1;                        ///< highest keyframe id whose job finished
  std::atomic<bool> hurry_{false};                            ///< finish(budget) is draining the queue: skip training
  std::atomic<bool> idle_paused_{false};                      ///< finish() runs: no idle training beside it
  bool live_ = false;                                         ///< set by start()
  std::chrono::steady_clock::time_point last_idle_snapshot_;  ///< worker thread only
};

}  // namespace dypho::mapping
