/// RealtimeRunner: a recorded sequence played through the pipeline at its stamps.
#include "dypho/pipeline/realtime_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "dypho/common/bounded_hand_over.h"

namespace dypho::pipeline {
namespace {

using Clock = std::chrono::steady_clock;

/// A frame on its way: released at `released`.
struct Released {
  std::size_t index = 0;
  Clock::time_point released;
  RealtimeInput input;
};

/// A masked frame on its way to tracking.
struct Masked {
  std::size_t index = 0;
  Clock::time_point released;
  MaskedFrame masked;
};

/// Longest single sleep while waiting for a frame's due time, so that `stop` is seen [ms].
constexpr int kStopPollMs = 20;
/// A release later than its due time by more than this counts as late (scheduler wake-up jitter
/// is not) [ms].
constexpr std::chrono::milliseconds kLateTolerance{5};

/// A frame read ahead of its release.
struct Loaded {
  std::size_t index = 0;
  RealtimeInput input;
};

/// Frames read ahead: the loader waits while `capacity` are ready (nothing is dropped here).
class PrefetchQueue {
 public:
  explicit PrefetchQueue(std::size_t capacity) : capacity_(capacity) {}
  /// Waits for room; false when closed (the item is discarded).
  bool push(Loaded item) {
    std::unique_lock<std::mutex> lock(mutex_);
    room_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
    if (closed_) return false;
    items_.push_back(std::move(item));
    lock.unlock();
    ready_.notify_one();
    return true;
  }
  /// Waits for the next frame; nullopt once closed and empty.
  std::optional<Loaded> pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [&] { return closed_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    std::optional<Loaded> item(std::move(items_.front()));
    items_.pop_front();
    lock.unlock();
    room_.notify_one();
    return item;
  }
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
  }

 private:
  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable ready_, room_;
  std::deque<Loaded> items_;
  bool closed_ = false;
};

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
  const std::size_t capacity = static_cast<std::size_t>(options_.queue_capacity_frames);
  BoundedHandOver<Released> camera_to_mask(capacity);
  BoundedHandOver<Masked> mask_to_tracking(capacity);
  RealtimeResult result;
  std::mutex result_mutex;  // the producer and the mask thread record drops
  std::atomic<bool> aborted{false};  // a stage threw: release nothing more
  auto stopped = [&] { return aborted.load() || (stop != nullptr && stop->load()); };

  // Loader: reads frames ahead of their release (at most prefetch_frames waiting), so that a slow
  // read delays no release while the reads keep ahead.
  PrefetchQueue prefetched(static_cast<std::size_t>(options_.prefetch_frames));
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
      if (!prefetched.push({i, std::move(*input)})) break;  // closed: the release stopped
    }
    prefetched.close();
  };

  // Camera: releases each frame at its due time; never waits for the pipeline.
  std::optional<Clock::time_point> first_release;
  auto producer = [&] {
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
      std::optional<Released> dropped = camera_to_mask.push({next->index, now, std::move(next->input)});
      std::lock_guard<std::mutex> lock(result_mutex);
      ++result.frames_in;
      if (dropped) result.dropped_before_mask.push_back(dropped->index);
    }
    prefetched.close();  // lets the loader end
    camera_to_mask.close();
  };

  std::exception_ptr mask_error;
  auto mask_worker = [&] {
    try {
      while (std::optional<Released> r = camera_to_mask.pop()) {
        Masked m{r->index, r->released, pipeline_.maskFrame(r->input.frame, r->input.external_mask)};
        std::optional<Masked> dropped = mask_to_tracking.push(std::move(m));
        if (dropped) {
          std::lock_guard<std::mutex> lock(result_mutex);
          result.dropped_before_tracking.push_back(dropped->index);
        }
      }
    } catch (...) {
      mask_error = std::current_exception();
      aborted = true;
      prefetched.close();
      camera_to_mask.close();
    }
    mask_to_tracking.close();
  };

  auto track = [&](std::size_t index, Clock::time_point released, MaskedFrame masked) {
    RealtimeProcessedFrame f;
    f.index = index;
    f.report = pipeline_.trackFrame(std::move(masked));
    f.latency_ms = std::chrono::duration<double, std::milli>(Clock::now() - released).count();
    std::lock_guard<std::mutex> lock(result_mutex);
    result.processed.push_back(std::move(f));
  };

  std::thread loader_thread(loader);
  std::thread producer_thread(producer);
  std::thread mask_thread;
  std::exception_ptr error;
  try {
    if (options_.pipelined) {
      mask_thread = std::thread(mask_worker);
      while (std::optional<Masked> m = mask_to_tracking.pop()) track(m->index, m->released, std::move(m->masked));
    } else {
      while (std::optional<Released> r = camera_to_mask.pop()) {
        track(r->index, r->released, pipeline_.maskFrame(r->input.frame, r->input.external_mask));
      }
    }
  } catch (...) {
    error = std::current_exception();
  }
  if (error) {
    // Let the other threads run out: nothing more is read, released or taken.
    aborted = true;
    prefetched.close();
    camera_to_mask.close();
    mask_to_tracking.close();
  }
  producer_thread.join();
  loader_thread.join();
  if (mask_thread.joinable()) mask_thread.join();
  if (error) std::rethrow_exception(error);
  if (mask_error) std::rethrow_exception(mask_error);

  std::lock_guard<std::mutex> lock(result_mutex);
  if (first_release) result.wall_s = std::chrono::duration<double>(Clock::now() - *first_release).count();
  result.stopped = stopped();
  return result;
}

}  // namespace dypho::pipeline
