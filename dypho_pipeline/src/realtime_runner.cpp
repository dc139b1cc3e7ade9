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

}  // namespace

void RealtimeOptions::validate() const {
  if (!(speed > 0.0) || !std::isfinite(speed)) {
    throw std::invalid_argument("realtime speed must be a finite factor > 0 (got " + std::to_string(speed) + ")");
  }
  if (prefetch_frames < 1) {
    throw std::invalid_argument("realtime prefetch_frames must be >= 1 (got " + std::to_string(prefetch_frames) + ")");
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
  return static_cast<std::size_t>(std::count_if(processed.begin(), processed.end(),
                                                [&](const RealtimeProcessedFrame& f) { return f.mask_source == source; }));
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
    changes.push_back("yolo_async forced on: the network runs on a worker and its newest mask is carried "
                      "to each frame with the flow (the live policy)");
  }
  return changes;
}

RealtimeRunner::RealtimeRunner(SlamPipeline& pipeline, const RealtimeOptions& options)
    : pipeline_(pipeline), options_(options) {
  options_.validate();
}

RealtimeResult RealtimeRunner::run(std::size_t num_frames, const RealtimeFrameLoader& load,
                                   const std::atomic<bool>* stop) {
  RealtimeResult result;
  std::mutex result_mutex;  // the camera, the mask and the tracking threads record
  std::atomic<bool> aborted{false};  // a stage threw: release nothing more
  std::exception_ptr error;          // the first one (under result_mutex)
  auto fail = [&](std::exception_ptr e) {
    std::lock_guard<std::mutex> lock(result_mutex);
    if (!error) error = std::move(e);
    aborted = true;
  };
  auto stopped = [&] { return aborted.load() || (stop != nullptr && stop->load()); };
  const bool expect_masks = pipeline_.options().mask_source != MaskSource::kNone;

  // Tracking: the tracking nodelet's live code; after each frame the pipeline hands its pose on.
  Live::Callbacks callbacks;
  callbacks.convert = toLiveFrame;
  callbacks.sink = [&](Live::Tracked& t) {
    RealtimeProcessedFrame f;
    f.index = t.ready.frame.index;
    f.mask_source = t.ready.source;
    f.mask_wait_ms = t.live.mask_wait_ms;
    f.report = pipeline_.handOnTracked(std::move(t.output), maskReportOf(t.ready));
    f.latency_ms = std::chrono::duration<double, std::milli>(Clock::now() - t.ready.frame.released).count();
    std::lock_guard<std::mutex> lock(result_mutex);
    result.processed.push_back(std::move(f));
  };
  callbacks.failure = [&](const tracking::LiveFailure& f) { fail(f.error); };
  Live live(pipeline_.tracking(), pipeline_.options().mask_pairing, expect_masks, std::move(callbacks));

  // Loader: reads frames ahead of their release (at most prefetch_frames waiting), so that a slow
  // read delays no release while the reads keep ahead.
  BoundedHandOver<Loaded> prefetched(static_cast<std::size_t>(options_.prefetch_frames));
  auto loader = [&] {
    for (std::size_t i = 0; i < num_frames && !stopped(); ++i) {
      std::optional<RealtimeInput> input;
      try {
        input = load(i);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(result_mutex);
        result.unreadable.push_back("frame " + std::to_string(i) + ": " + e.what());
        continue;
      }
      if (!prefetched.pushWhenRoom({i, std::move(*input)})) break;  // closed: the release stopped
    }
    prefetched.close();
  };

  // Camera: releases each frame at its due time to the mask stage and to tracking; never waits
  // for either.
  BoundedHandOver<ToMask> camera_to_mask(static_cast<std::size_t>(options_.queue_capacity_frames));
  std::optional<Clock::time_point> first_release;
  auto release = [&](Loaded next, Clock::time_point now) {
    const Timestamp stamp_ns = next.input.frame.stamp_ns;
    std::optional<LiveInput> dropped = live.addFrame(stamp_ns, LiveInput{next.index, now, next.input.frame});
    std::optional<ToMask> skipped;
    if (expect_masks) skipped = camera_to_mask.push({next.index, std::move(next.input)});
    std::lock_guard<std::mutex> lock(result_mutex);
    ++result.frames_in;
    if (dropped) result.dropped_before_tracking.push_back(dropped->index);
    if (skipped) result.masks_skipped.push_back(skipped->index);
  };
  auto camera = [&] {
    std::optional<Timestamp> first_stamp;
    while (!stopped()) {
      std::optional<Loaded> next = prefetched.pop();
      if (!next) break;
      Clock::time_point now = Clock::now();
      if (!first_stamp) {
        first_stamp = next->input.frame.stamp_ns;
        first_release = now;
      } else {
        const double offset_s = timestampToSeconds(next->input.frame.stamp_ns - *first_stamp) / options_.speed;
        const Clock::time_point due =
            *first_release + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(offset_s));
        if (now > due + kLateTolerance) {
          std::lock_guard<std::mutex> lock(result_mutex);
          ++result.late_releases;
        }
        while (now < due && !stopped()) {
          std::this_thread::sleep_for(std::min<Clock::duration>(due - now, std::chrono::milliseconds(kStopPollMs)));
          now = Clock::now();
        }
        if (stopped()) break;
      }
      release(std::move(*next), now);
    }
    prefetched.close();  // lets the loader end
    camera_to_mask.close();
  };

  // Mask stage (the mask nodelet): masks the oldest waiting frame; tracking gets each mask as it
  // is done. A frame the stage rejects for its stamp gets no mask (tracking rejects it too).
  auto mask_worker = [&] {
    while (std::optional<ToMask> m = camera_to_mask.pop()) {
      if (aborted) continue;  // drain: the run ends
      try {
        auto masked = std::make_shared<MaskedFrame>(pipeline_.maskFrame(m->input.frame, m->input.external_mask));
        if (!masked->report.dropped) live.addMask(masked->frame.stamp_ns, std::move(masked));
      } catch (...) {
        fail(std::current_exception());
        prefetched.close();
      }
    }
  };

  std::thread loader_thread(loader);
  std::thread camera_thread(camera);
  std::thread mask_thread(mask_worker);
  camera_thread.join();
  loader_thread.join();
  mask_thread.join();
  live.finish();  // every released frame not dropped reaches the sink

  std::lock_guard<std::mutex> lock(result_mutex);
  if (error) std::rethrow_exception(error);
  if (first_release) result.wall_s = std::chrono::duration<double>(Clock::now() - *first_release).count();
  result.stopped = stopped();
  result.live = live.counters();
  return result;
}

}  // namespace dypho::pipeline
