#pragma once
/// \file mapping_worker.h
/// The mapping worker thread and its bounded job queue. Jobs (a keyframe to integrate and train
/// on, or a batch of keyframe pose corrections) run one after the other in arrival order, so the
/// map's history does not depend on timing.
///
/// Queue policy when `capacity` jobs wait (one place, chosen per push):
///  - block_when_full: the producer waits for room (deterministic offline runs);
///  - otherwise the oldest waiting *keyframe* job is dropped and counted (live input must not
///    pile up); correction batches are never dropped (they are small, and a lost correction
///    would leave a keyframe's Gaussians at a stale pose for good).

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>

#include "dypho/common/thread_budget.h"
#include "dypho/common/types.h"

namespace dypho::mapping {

/// One unit of mapping work.
struct MappingJob {
  KeyframeConstPtr keyframe;            ///< integrate this keyframe, then train (may be null)
  KeyframePoseCorrections corrections;  ///< re-anchor these keyframes (may be empty)
};

class MappingWorker {
 public:
  /// Runs `handler` on the worker thread for every job. `capacity` >= 1 waiting jobs.
  /// `idle_handler` (optional): called again and again while no job waits; it does one small
  /// step of background work and returns false when there is none (the worker then sleeps until
  /// the next job). The thread lowers its priority to `priority` (thread_budget.h).
  MappingWorker(std::size_t capacity, std::function<void(const MappingJob&)> handler,
                std::function<bool()> idle_handler = {}, ThreadPriority priority = {});
  ~MappingWorker();  ///< stop()
  MappingWorker(const MappingWorker&) = delete;
  MappingWorker& operator=(const MappingWorker&) = delete;

  /// Queues a job (policy in the file comment). Returns false when a keyframe had to be dropped.
  bool push(MappingJob job, bool block_when_full);
  /// Waits until no job waits or runs.
  void waitUntilIdle();
  /// True when stop() was called (the handler may poll it to end a long job early).
  bool stopping() const;
  /// Discards the waiting jobs (the running one finishes).
  void clear();
  /// Stops and joins the thread; waiting jobs are discarded.
  void stop();
  std::size_t queued() const;   ///< jobs waiting
  std::size_t dropped() const;  ///< keyframe jobs dropped by the live policy so far

 private:
  void loop();

  std::function<void(const MappingJob&)> handler_;
  std::function<bool()> idle_handler_;
  ThreadPriority priority_;
  std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<MappingJob> queue_;
  bool busy_ = false;
  bool stop_ = false;
  // Mirrors written under mutex_ and read without it: queued() and dropped() are read by ROS
  // timer threads (stats, diagnostics) and must not wait for a worker thread of the idle class
  // that was preempted inside its lock.
  std::atomic<std::size_t> queued_{0};
  std::atomic<std::size_t> dropped_{0};
  std::thread thread_;
};

}  // namespace dypho::mapping
