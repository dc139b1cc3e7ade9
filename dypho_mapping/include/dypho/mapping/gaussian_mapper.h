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
/// Threads: every public function is thread-safe (one mutex guards the map). With `start()`, a
/// worker thread takes keyframes from a bounded queue, seeds them and runs
/// `iterations_per_keyframe` iterations after each (in order, so results do not depend on timing);
/// the lock is released between iterations, so a render waits at most one iteration.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mapping/gaussian_mapper_options.h"

namespace dypho::mapping {

/// Result of integrating one keyframe.
struct AddKeyframeResult {
  bool added = false;             ///< false: skipped, `message` says why
  std::size_t new_gaussians = 0;  ///< Gaussians seeded
  bool capacity_reached = false;  ///< seeding stopped at max_gaussians
  std::string message;            ///< why it was skipped / what was capped
};

/// Counters of the mapper.
struct GaussianMapperStats {
  std::size_t num_gaussians = 0;        ///< Gaussians in the map
  std::size_t num_keyframes = 0;        ///< keyframes integrated (poses kept)
  std::size_t num_stored_images = 0;    ///< keyframes whose images are kept
  std::int64_t iterations = 0;          ///< optimisation iterations run
  std::size_t queued = 0;               ///< keyframes waiting for the worker
  std::size_t dropped_keyframes = 0;    ///< dropped because the queue was full (non-blocking enqueue)
  std::size_t skipped_keyframes = 0;    ///< rejected (bad pose, no depth, ...)
  std::size_t capacity_hits = 0;        ///< times seeding or densification stopped at the cap
  double last_loss = 0.0;               ///< loss of the last iteration
};

/// PSNR and depth error of the map rendered at the stored keyframes (training resolution).
struct KeyframeEvaluation {
  std::size_t num_keyframes = 0;  ///< keyframes evaluated
  /// Mean over keyframes of the PSNR on static pixels [dB]; with exposure_compensation the
  /// rendered colour goes through the keyframe's exposure first (exp(k) * rendered + b).
  double psnr_db = 0.0;
  double psnr_without_exposure_db = 0.0;  ///< the same with the plain rendered colour [dB]
  double depth_l1_m = 0.0;        ///< mean |Dr - D| over static pixels with valid depth [m]
  std::vector<double> psnr_per_keyframe_db;  ///< in keyframe order
};

/// A rendered view.
struct RenderedView {
  cv::Mat bgr;      ///< CV_8UC3 BGR
  /// CV_32FC1 [m]: D_r / alpha (D_r = sum d_i alpha_i T_i) where alpha >= 0.5, else 0 (no
  /// measurement). The alpha term of the loss keeps alpha ~1 on measured surfaces, where this is D_r.
  cv::Mat depth_m;
  cv::Mat alpha;    ///< CV_32FC1 accumulated alpha in [0, 1]
};

/// One Gaussian centre with its colour (for point clouds).
struct GaussianCentre {
  float x, y, z;         ///< world [m]
  std::uint8_t r, g, b;  ///< DC colour
};

class GaussianMapper {
 public:
  /// Validates `options` (std::invalid_argument).
  explicit GaussianMapper(const GaussianMapperOptions& options);
  ~GaussianMapper();  ///< stops the worker (pending keyframes are discarded)
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
  /// Starts the worker with a queue of `queue_capacity` keyframes (no-op when running).
  void start(std::size_t queue_capacity);
  /// Hands a keyframe to the worker. When the queue is full: with `block_when_full` waits for
  /// room (deterministic offline runs); otherwise drops the oldest queued keyframe and returns
  /// false (ROS callbacks). Without a running worker, integrates and optimises synchronously.
  bool enqueueKeyframe(KeyframeConstPtr keyframe, bool block_when_full);
  /// Waits until the queue is empty and the worker has finished its iterations.
  void waitUntilIdle();
  /// End of a sequence: waitUntilIdle(), then `final_refine_iterations` iterations over all stored
  /// keyframes (shuffled passes, each keyframe equally often) on the calling thread. Call it once
  /// before the final map is saved or evaluated. Returns the mean loss of those iterations (0: none).
  double finish();
  /// Stops and joins the worker (remaining queued keyframes are discarded).
  void stop();
  /// Receives one line per skipped keyframe or notable event from the worker (optional).
  void setMessageSink(std::function<void(const std::string&)> sink);

  // --- queries (thread-safe) -----------------------------------------------------------------
  /// Re-anchors the Gaussians seeded from keyframe `id` after a pose correction; false when the
  /// id is unknown or the pose is not finite/rigid.
  bool updateKeyframePose(std::int64_t id, const Eigen::Isometry3d& T_world_camera);
  /// Colour, depth and alpha seen from `T_world_camera` through `camera` (size and distortion of
  /// `camera`). Throws std::invalid_argument for invalid intrinsics or a non-finite pose.
  RenderedView render(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const;
  /// Depth only (CV_32FC1 [m], 0 = nothing rendered), same geometry as render().
  cv::Mat renderDepth(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const;
  /// PSNR on static pixels and depth L1 at the stored keyframes. When `side_by_side_dir` is not
  /// empty, writes `kf_<id>.png` there (input | rendered colour (after the keyframe's exposure)
  /// over input depth | rendered depth).
  KeyframeEvaluation evaluateKeyframes(const std::string& side_by_side_dir = "") const;
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
  /// Removes every Gaussian and keyframe (the worker keeps running).
  void reset();
  const GaussianMapperOptions& options() const { return options_; }

 private:
  struct Impl;
  void workerLoop();
  GaussianMapperOptions options_;
  std::unique_ptr<Impl> impl_;  ///< map, optimiser, keyframes, rasterizers (guarded by mutex_)
  mutable std::mutex mutex_;

  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<KeyframeConstPtr> queue_;
  std::size_t queue_capacity_ = 1;
  bool worker_busy_ = false;
  bool stop_ = false;
  std::thread worker_;
  std::function<void(const std::string&)> sink_;
  std::atomic<std::size_t> dropped_{0};
};

}  // namespace dypho::mapping
