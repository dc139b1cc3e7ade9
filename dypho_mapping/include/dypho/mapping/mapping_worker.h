#pragma once
/// \file mapping_worker.h
/// The mapping worker thread and its bounded job queue. Jobs (a keyframe to integrate and train
/// on, or a batch of keyframe pose corrections) run one after the other in arrival order, so the
/// map's history does not depend on timing.
///
/// Queue policy when `capacity` jobs wait (one place, chosen per push):
///  - block_when_full: the producer waits for room (deterministic offline runs);
///  - otherwise the new job is merged into the newest waiting one (live input must not pile up
///    as jobs): nothing is ever dropped. A merged job holds several keyframes; the handler seeds
///    them all and shares the training out, so when mapping is behind only training waits.

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "dypho/common/thread_budget.h"
#include "dypho/common/types.h"

namespace dypho::mapping {

/// One unit of mapping work: first the keyframes are integrated (in order), then the corrections
/// are applied (in order). Corrections carry absolute poses and name only keyframes sent before
/// them, so this order gives every keyframe its latest pose also when jobs were merged.
struct MappingJob {
  std::vector<KeyframeConstPtr> keyframes;  ///< integrate these keyframes, then train (may be empty)
  KeyframePoseCorrections corrections;      ///< re-anchor these keyframes (may be empty)
  /// Appends `later`'s keyframes and corrections (the merge of the live policy).
  void merge(MappingJob&& later);
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

  /// Queues a job (policy in the file comment). Returns false when it was merged into a waiting
  /// job because the queue was full (nothing is lost).
  bool push(MappingJob job, bool block_when_full);
  /// Waits until no job waits or runs.
  void waitUntilIdle();
  /// True when stop() was called (the handler may poll it to end a long job early).
  bool stopping() const;
  /// Discards the waiting jobs (the running one finishes).
  void clear();
  /// Stops and joins the thread; waiting jobs are discarded.
  void stop();
  std::size_t queued() const;  ///< jobs waiting
  std::size_t merged() const;  ///< jobs merged into a waiting one by the live policy so far

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
  // Mirrors written under mutex_ and read without it: queued() and merged() are read by ROS
  // timer threads (stats, diagnostics) and must not wait for a worker thread of the idle class
  // that was preempted inside its lock.
  std::atomic<std::size_t> queued_{0};
  std::atomic<std::size_t> merged_{0};
  std::thread thread_;
};

}  // namespace dypho::mapping
