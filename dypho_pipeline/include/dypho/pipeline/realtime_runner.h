#pragma once
/// \file realtime_runner.h
/// Runs a recorded sequence through SlamPipeline as a live camera would deliver it, through the
/// same live code as the ROS graph, so that the offline numbers predict the graph's
/// (dypho_run_dataset --realtime).
///
///  - A loader thread reads frames ahead (at most `prefetch_frames`), and a camera thread releases
///    frame i at its stamp on the wall clock, counted from the first frame's release:
///    due(i) = t_0 + (stamp_i - stamp_0) / speed. The camera never waits for the pipeline; a frame
///    not read by its due time is released as soon as it is (counted as late).
///  - Each released frame goes, as the camera's topics go to both nodelets, (a) to the mask
///    stage's thread through a bounded hand-over (`queue_capacity_frames`; when full the oldest
///    frame is skipped by the mask, as the mask nodelet's ~max_waiting_frames does), and (b) to a
///    tracking::LiveTracker, the tracking nodelet's own live code: it pairs each frame with its
///    mask (waits at most mask_pairing.max_wait_s, then carries the nearest mask or none), drops
///    a frame beyond mask_pairing.max_pending_frames (counted; every other one of a backlog), prepares features on one
///    thread and tracks on another. The mask thread gives each mask to the live tracker as it
///    finishes it. Dropped frames are never tracked and have no pose in the trajectory.
///  - After tracking, the pipeline hands the pose on (SlamPipeline::handOnTracked: mask and
///    mapping stages, keyframes and corrections to mapping), on the tracking thread.
///  - Latency of a frame: from its release to the end of its tracking (the pose).
/// The policy of the stages belongs to the caller: build the SlamPipeline with
/// MappingMode::kLive and the options passed through applyLivePolicy() for the graph's policy;
/// PipelineOptions::mask_pairing holds the tracking nodelet's pairing parameters.
/// Not deterministic: which frames are dropped or carried depends on the machine's load.

#include <atomic>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/pipeline/pipeline_options.h"
#include "dypho/pipeline/slam_pipeline.h"
#include "dypho/tracking/live_tracker.h"

namespace dypho::pipeline {

/// Settings of the realtime run.
struct RealtimeOptions {
  /// Playback speed: the stamps' time passes this many times faster than wall time [factor];
  /// default 1.0 (the camera's rate), > 0 and finite.
  double speed = 1.0;
  /// Frames waiting for the mask stage before the oldest is skipped (the mask nodelet's
  /// ~max_waiting_frames) [count]; default 2, >= 1. A skipped frame is still tracked, with the
  /// nearest mask in time or none (PipelineOptions::mask_pairing).
  int queue_capacity_frames = 2;
  /// Frames read ahead of their release, so that a slow read does not delay one [count];
  /// default 8, >= 1.
  int prefetch_frames = 8;
  /// The mask a frame was tracked with is kept in its RealtimeProcessedFrame when its index is a
  /// multiple of this (the runner's map evaluation at every Nth frame) [count]; default 0: none.
  int keep_masks_every_nth = 0;

  /// Throws std::invalid_argument naming the bad field and its accepted range.
  void validate() const;
};

/// One frame as the loader gives it.
struct RealtimeInput {
  RgbdFrame frame;        ///< images, stamp, camera
  cv::Mat external_mask;  ///< for MaskSource::kExternal (CV_8UC1, 255 = dynamic); else empty
};

/// Loads frame `index` (0-based); throws on an unreadable frame (it is skipped and named).
using RealtimeFrameLoader = std::function<RealtimeInput(std::size_t index)>;

/// A frame that went through the pipeline.
struct RealtimeProcessedFrame {
  std::size_t index = 0;  ///< position in the sequence
  /// As SlamPipeline::process() reports it (report.dropped: stamp rejected). The render and
  /// mask fields are those of the frame's own mask; zero when it was tracked with a carried
  /// mask or none.
  FrameReport report;
  double latency_ms = 0.0;                                         ///< release to pose (end of tracking) [ms]
  tracking::MaskSource mask_source = tracking::MaskSource::kNone;  ///< the mask it was tracked with
  double mask_wait_ms = 0.0;                                       ///< its wait for that mask [ms]
  /// That mask (CV_8UC1, 255 = dynamic; shared, not copied) when RealtimeOptions::keep_masks_every_nth
  /// selects this frame; else empty.
  cv::Mat mask;
};

/// Outcome of RealtimeRunner::run().
struct RealtimeResult {
  std::size_t frames_in = 0;  ///< frames released by the camera
  /// In the order tracking finished them (stamp order).
  /// Invariant: frames_in == processed.size() + framesDropped().
  std::vector<RealtimeProcessedFrame> processed;
  /// Indices dropped while waiting for their mask or for tracking (beyond
  /// mask_pairing.max_pending_frames): never tracked, no pose.
  std::vector<std::size_t> dropped_before_tracking;
  /// Indices of frames the mask stage skipped (its hand-over was full): tracked all the same,
  /// with a carried mask or none (or dropped, then also listed above).
  std::vector<std::size_t> masks_skipped;
  std::vector<std::string> unreadable;  ///< frames the loader could not read ("frame i: why"), never released
  std::size_t late_releases = 0;        ///< frames released over 5 ms after their due time (reading fell behind)
  double wall_s = 0.0;                  ///< from the first release to the last frame's pose [s]
  bool stopped = false;                 ///< the stop flag ended the run early
  tracking::LiveCounters live;          ///< the live tracker's counters (the tracking nodelet's status figures)

  std::size_t framesDropped() const { return dropped_before_tracking.size(); }
  /// Processed frames with a pose (not rejected for their stamp).
  std::size_t framesPosed() const;
  /// Processed frames tracked with the given mask source.
  std::size_t framesWithMask(tracking::MaskSource source) const;
  /// Latency percentile of the processed frames with a pose, `q` in [0, 1] [ms]; 0 when none.
  double latencyPercentileMs(double q) const;
};

/// Switches `options` to the graph's live policy; returns one line per change, for the log:
/// the YOLO network runs asynchronously (yolo_async) when a model is configured.
std::vector<std::string> applyLivePolicy(PipelineOptions& options);

/// The q-quantile of `values` (nearest rank, q in [0, 1]); 0 for none.
double percentile(std::vector<double> values, double q);

class RealtimeRunner {
 public:
  /// Validates `options` (std::invalid_argument). `pipeline` must outlive the runner.
  RealtimeRunner(SlamPipeline& pipeline, const RealtimeOptions& options);

  /// Plays frames [0, num_frames) through the pipeline at their stamps. `stop` (optional, e.g.
  /// set by a signal handler): no frame is released after it is set; frames already released
  /// finish. Does not call SlamPipeline::finish(). A stage that throws ends the run: nothing more
  /// is released, the threads end, and the first exception is rethrown.
  RealtimeResult run(std::size_t num_frames, const RealtimeFrameLoader& load, const std::atomic<bool>* stop = nullptr);

 private:
  SlamPipeline& pipeline_;
  RealtimeOptions options_;
};

}  // namespace dypho::pipeline
