#pragma once
/// \file realtime_runner.h
/// Runs a recorded sequence through SlamPipeline as a live camera would deliver it, so that the
/// offline numbers predict the graph's (dypho_run_dataset --realtime).
///
///  - A loader thread reads frames ahead (at most `prefetch_frames`), and a camera thread releases
///    frame i at its stamp on the wall clock, counted from the first frame's release:
///    due(i) = t_0 + (stamp_i - stamp_0) / speed. The camera never waits for the pipeline; a frame
///    not read by its due time is released as soon as it is (counted as late).
///  - Released frames go into a bounded hand-over (BoundedHandOver, `queue_capacity_frames`);
///    when the pipeline has not taken them in time the oldest is dropped and counted. Dropped
///    frames are never processed and have no pose in the trajectory.
///  - Pipelined (default): the mask stage runs on its own thread and hands masked frames through
///    a second hand-over of the same capacity to tracking on the calling thread, so frame k is
///    tracked while frame k+1 is masked (the graph's mask and tracking nodelets). Not pipelined:
///    one thread masks and tracks each frame in turn.
///  - Latency of a frame: from its release to the end of its tracking (the pose).
/// The policy of the stages belongs to the caller: build the SlamPipeline with
/// MappingMode::kLive and the options passed through applyLivePolicy() for the graph's policy.
/// Not deterministic: which frames are dropped depends on the machine's load.

#include <atomic>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/pipeline/pipeline_options.h"
#include "dypho/pipeline/slam_pipeline.h"

namespace dypho::pipeline {

/// Settings of the realtime run.
struct RealtimeOptions {
  /// Playback speed: the stamps' time passes this many times faster than wall time [factor];
  /// default 1.0 (the camera's rate), > 0 and finite.
  double speed = 1.0;
  /// Frames each hand-over holds (camera -> mask, mask -> tracking) before the oldest is dropped
  /// [count]; default 2, >= 1. With 1 the pipeline always takes the newest frame.
  int queue_capacity_frames = 2;
  /// Frames read ahead of their release, so that a slow read does not delay one [count];
  /// default 8, >= 1.
  int prefetch_frames = 8;
  /// Mask and tracking on two threads, overlapping consecutive frames (the graph's nodelets);
  /// default true. false: mask then tracking on one thread per frame.
  bool pipelined = true;

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
  std::size_t index = 0;    ///< position in the sequence
  FrameReport report;       ///< as SlamPipeline::process() reports it (report.dropped: stamp rejected)
  double latency_ms = 0.0;  ///< release to pose (end of tracking) [ms]
};

/// Outcome of RealtimeRunner::run().
struct RealtimeResult {
  std::size_t frames_in = 0;  ///< frames released by the producer
  /// In the order tracking finished them. Invariant: frames_in == processed.size() + framesDropped().
  std::vector<RealtimeProcessedFrame> processed;
  std::vector<std::size_t> dropped_before_mask;      ///< indices dropped at the camera -> mask hand-over
  std::vector<std::size_t> dropped_before_tracking;  ///< indices dropped at the mask -> tracking hand-over
  std::vector<std::string> unreadable;  ///< frames the loader could not read ("frame i: why"), never released
  std::size_t late_releases = 0;  ///< frames released over 5 ms after their due time (reading fell behind)
  double wall_s = 0.0;            ///< from the first release to the last frame's pose [s]
  bool stopped = false;           ///< the stop flag ended the run early

  std::size_t framesDropped() const { return dropped_before_mask.size() + dropped_before_tracking.size(); }
  /// Processed frames with a pose (not rejected for their stamp).
  std::size_t framesPosed() const;
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
  /// finish. Does not call SlamPipeline::finish().
  RealtimeResult run(std::size_t num_frames, const RealtimeFrameLoader& load,
                     const std::atomic<bool>* stop = nullptr);

 private:
  SlamPipeline& pipeline_;
  RealtimeOptions options_;
};

}  // namespace dypho::pipeline
