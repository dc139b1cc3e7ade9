/// RealtimeRunner: a recorded sequence played through the pipeline at its stamps.
#include "dypho/pipeline/realtime_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "dypho/common/bounded_hand_over.h"

namespace dypho::pipeline {
namespace {

using Clock = std::chrono::steady_clock;

/// A frame read ahead of its release.
struct Loaded {
  std::size_t index = 0;
  RealtimeInput input;
};

/// A released frame on its way to the mask stage.
struct ToMask {
  std::size_t index = 0;
  RealtimeInput input;
};

/// A released frame as the live tracker holds it (the tracking nodelet holds message pointers).
struct LiveInput {
  std::size_t index = 0;
  Clock::time_point released;
  RgbdFrame frame;
};

/// A finished mask, shared by the frames it is carried to.
using MaskPtr = std::shared_ptr<const MaskedFrame>;
using Live = tracking::LiveTracker<LiveInput, MaskPtr>;

/// Longest single sleep while waiting for a frame's due time, so that `stop` is seen [ms].
constexpr int kStopPollMs = 20;
/// A release later than its due time by more than this counts as late (scheduler wake-up jitter
/// is not) [ms].
constexpr std::chrono::milliseconds kLateTolerance{5};

/// The live tracker's conversion: the frame and the mask it was paired with, as the mask stage
/// judged it.
tracking::LiveFrame toLiveFrame(const Live::Ready& ready) {
  tracking::LiveFrame out;
  out.frame = ready.frame.frame;
  if (ready.mask) {
    out.mask = ready.mask->mask;
    out.own_mask_judgement = ready.mask->judgement;
  }
  return out;
}

/// The report of a tracked frame before its hand-on: the mask stage's fields of its own mask;
/// a carried mask's degradation and masked share (the work was another frame's).
FrameReport maskReportOf(const Live::Ready& ready) {
  FrameReport report;
  if (!ready.mask) return report;
  if (ready.source == tracking::MaskSource::kMatched) return ready.mask->report;
  report.masked_fraction = ready.mask->report.masked_fraction;
  report.mask_degraded = ready.mask->report.mask_degraded;
  return report;
}

/// One run: the threads (loader, camera, mask; the live tracker's two) and what they record.
class RealtimeRun {
 public:
  RealtimeRun(SlamPipeline& pipeline, const RealtimeOptions& options, const std::atomic<bool>* stop)
      : pipeline_(pipeline),
        options_(options),
        stop_(stop),
        expect_masks_(pipeline.options().mask_source != MaskSource::kNone),
        prefetched_(static_cast<std::size_t>(options.prefetch_frames)),
        camera_to_mask_(static_cast<std::size_t>(options.queue_capacity_frames)),
        live_(pipeline.tracking(), pipeline.options().mask_pairing, expect_masks_, liveCallbacks()) {}

  RealtimeResult run(std::size_t num_frames, const RealtimeFrameLoader& load) {
    std::thread loader_thread([&] { readAhead(num_frames, load); });
    std::thread camera_thread([&] { releaseAtStamps(); });
    std::thread mask_thread([&] { maskFrames(); });
    camera_thread.join();
    loader_thread.join();
    mask_thread.join();
    live_.finish();  // every released frame not dropped reaches the sink

    std::lock_guard<std::mutex> lock(result_mutex_);
    if (error_) std::rethrow_exception(error_);
    if (first_release_) result_.wall_s = std::chrono::duration<double>(Clock::now() - *first_release_).count();
    result_.stopped = stopped();
    result_.live = live_.counters();
    return std::move(result_);
  }

 private:
  bool stopped() const { return aborted_.load() || (stop_ != nullptr && stop_->load()); }

  /// A stage threw: release nothing more; run() rethrows the first error.
  void fail(std::exception_ptr e) {
    {
      std::lock_guard<std::mutex> lock(result_mutex_);
      if (!error_) error_ = std::move(e);
    }
    aborted_ = true;
    prefetched_.close();
  }

  /// Tracking: the tracking nodelet's live code; after each frame the pipeline hands its pose on.
  Live::Callbacks liveCallbacks() {
    Live::Callbacks callbacks;
    callbacks.convert = toLiveFrame;
    callbacks.sink = [this](Live::Tracked& t) { onTracked(t); };
    callbacks.failure = [this](const tracking::LiveFailure& f) { fail(f.error); };
    return callbacks;
  }

  void onTracked(Live::Tracked& t) {
    RealtimeProcessedFrame f;
    f.index = t.ready.frame.index;
    f.mask_source = t.ready.source;
    f.mask_wait_ms = t.live.mask_wait_ms;
    const int keep = options_.keep_masks_every_nth;
    if (keep > 0 && t.ready.mask && f.index % static_cast<std::size_t>(keep) == 0) f.mask = t.ready.mask->mask;
    f.report = pipeline_.handOnTracked(std::move(t.output), maskReportOf(t.ready));
    f.latency_ms = std::chrono::duration<double, std::milli>(Clock::now() - t.ready.frame.released).count();
    std::lock_guard<std::mutex> lock(result_mutex_);
    result_.processed.push_back(std::move(f));
  }

  /// Loader: reads frames ahead of their release (at most prefetch_frames waiting), so that a
  /// slow read delays no release while the reads keep ahead.
  void readAhead(std::size_t num_frames, const RealtimeFrameLoader& load) {
    for (std::size_t i = 0; i < num_frames && !stopped(); ++i) {
      std::optional<RealtimeInput> input;
      try {
        input = load(i);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(result_mutex_);
        result_.unreadable.push_back("frame " + std::to_string(i) + ": " + e.what());
        continue;
      }
      if (!prefetched_.pushWhenRoom({i, std::move(*input)})) break;  // closed: the release stopped
    }
    prefetched_.close();
  }

  /// Camera: releases each frame at its due time; never waits for the mask or tracking.
  void releaseAtStamps() {
    std::optional<Timestamp> first_stamp;
    while (!stopped()) {
      std::optional<Loaded> next = prefetched_.pop();
      if (!next) break;
      Clock::time_point now = Clock::now();
      if (!first_stamp) {
        first_stamp = next->input.frame.stamp_ns;
        first_release_ = now;
      } else {
        const double offset_s = timestampToSeconds(next->input.frame.stamp_ns - *first_stamp) / options_.speed;
        now = waitUntil(*first_release_ +
                        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(offset_s)));
        if (stopped()) break;
      }
      release(std::move(*next), now);
    }
    prefetched_.close();  // lets the loader end
    camera_to_mask_.close();
  }

  /// Sleeps until `due` or a stop; returns the time it woke. A frame already late is counted.
  Clock::time_point waitUntil(Clock::time_point due) {
    Clock::time_point now = Clock::now();
    if (now > due + kLateTolerance) {
      std::lock_guard<std::mutex> lock(result_mutex_);
      ++result_.late_releases;
    }
    while (now < due && !stopped()) {
      std::this_thread::sleep_for(std::min<Clock::duration>(due - now, std::chrono::milliseconds(kStopPollMs)));
      now = Clock::now();
    }
    return now;
  }

  /// The frame goes to tracking and to the mask stage, as the camera's topics go to both nodelets.
  void release(Loaded next, Clock::time_point now) {
    const Timestamp stamp_ns = next.input.frame.stamp_ns;
    std::optional<LiveInput> dropped = live_.addFrame(stamp_ns, LiveInput{next.index, now, next.input.frame});
    std::optional<ToMask> skipped;
    if (expect_masks_) skipped = camera_to_mask_.push({next.index, std::move(next.input)});
    std::lock_guard<std::mutex> lock(result_mutex_);
    ++result_.frames_in;
    if (dropped) result_.dropped_before_tracking.push_back(dropped->index);
    if (skipped) result_.masks_skipped.push_back(skipped->index);
  }

  /// Mask stage (the mask nodelet): masks the oldest waiting frame; tracking gets each mask as it
  /// is done. A frame the stage rejects for its stamp gets no mask (tracking rejects it too).
  void maskFrames() {
    while (std::optional<ToMask> m = camera_to_mask_.pop()) {
      if (aborted_) continue;  // drain: the run ends
      try {
        auto masked = std::make_shared<MaskedFrame>(
            pipeline_.maskFrame(m->input.frame, m->input.external_mask, camera_to_mask_.size()));
        const Timestamp stamp_ns = masked->frame.stamp_ns;
        if (!masked->report.dropped) live_.addMask(stamp_ns, std::move(masked));
      } catch (...) {
        fail(std::current_exception());
      }
    }
  }

  SlamPipeline& pipeline_;
  const RealtimeOptions options_;
  const std::atomic<bool>* stop_;
  const bool expect_masks_;
  std::atomic<bool> aborted_{false};
  std::mutex result_mutex_;  ///< the camera, the mask and the tracking threads record
  RealtimeResult result_;
  std::exception_ptr error_;                        ///< the first error of a stage (under result_mutex_)
  std::optional<Clock::time_point> first_release_;  ///< written by the camera, read after it ended
  BoundedHandOver<Loaded> prefetched_;
  BoundedHandOver<ToMask> camera_to_mask_;
  Live live_;  ///< last: its threads use the members above, and its destructor stops them first
};

}  // namespace

void RealtimeOptions::validate() const {
  if (!(speed > 0.0) || !std::isfinite(speed)) {
    throw std::invalid_argument("realtime speed must be a finite factor > 0 (got " + std::to_string(speed) + ")");
  }
  if (prefetch_frames < 1) {
    throw std::invalid_argument("realtime prefetch_frames must be >= 1 (got " + std::to_string(prefetch_frames) + ")");
  }
  if (keep_masks_every_nth < 0) {
    throw std::invalid_argument("realtime keep_masks_every_nth must be >= 0 (got " +
                                std::to_string(keep_masks_every_nth) + ")");
  }
  if (queue_capacity_frames < 1) {
    throw std::invalid_argument("realtime queue_capacity_frames must be >= 1 (got " +
                                std::to_string(queue_capacity_frames) + ")");
  }
}

std::size_t RealtimeResult::framesPosed() const {
  return static_cast<std::size_t>(std::count_if(processed.begin(), processed.end(),
                                                [](const RealtimeProcessedFrame& f) { return !f.report.dropped; }));
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  q = std::clamp(q, 0.0, 1.0);
  // Nearest rank: the smallest value with at least q of the values at or below it.
  const std::size_t rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  const std::size_t k = rank == 0 ? 0 : rank - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

std::size_t RealtimeResult::framesWithMask(tracking::MaskSource source) const {
  return static_cast<std::size_t>(std::count_if(
      processed.begin(), processed.end(), [&](const RealtimeProcessedFrame& f) { return f.mask_source == source; }));
}

double RealtimeResult::latencyPercentileMs(double q) const {
  std::vector<double> latencies;
  for (const RealtimeProcessedFrame& f : processed) {
    if (!f.report.dropped) latencies.push_back(f.latency_ms);
  }
  return percentile(std::move(latencies), q);
}

std::vector<std::string> applyLivePolicy(PipelineOptions& options) {
  std::vector<std::string> changes;
  if (!options.mask.yolo.model_path.empty() && !options.mask.yolo.async) {
    options.mask.yolo.async = true;
    changes.push_back(
        "yolo_async forced on: the network runs on a worker and its newest mask is carried "
        "to each frame with the flow (the live policy)");
  }
  return changes;
}

RealtimeRunner::RealtimeRunner(SlamPipeline& pipeline, const RealtimeOptions& options)
    : pipeline_(pipeline), options_(options) {
  options_.validate();
  if (pipeline_.options().mask_poses_one_frame_late) {
    throw std::invalid_argument(
        "mask_poses_one_frame_late is for deterministic runs: live, the poses come when they come");
  }
}

RealtimeResult RealtimeRunner::run(std::size_t num_frames, const RealtimeFrameLoader& load,
                                   const std::atomic<bool>* stop) {
  RealtimeRun run(pipeline_, options_, stop);
  return run.run(num_frames, load);
}

}  // namespace dypho::pipeline
