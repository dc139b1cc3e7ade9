#pragma once
/// \file thread_pool.h
/// A small fixed pool of worker threads for data-parallel loops (tiles, Gaussians). The calling
/// thread takes part, so `num_threads` = 2 means one extra thread. Not re-entrant: one
/// parallelFor at a time per pool.

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "dypho/common/thread_budget.h"

namespace dypho::mapping {

class ThreadPool {
 public:
  /// `num_threads` >= 1 threads in total (including the caller of parallelFor). The extra
  /// threads lower their priority to `priority` (thread_budget.h), so a pool of a background job
  /// yields to the camera-rate threads; the caller keeps its own priority.
  explicit ThreadPool(int num_threads, ThreadPriority priority = {});
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int numThreads() const { return num_threads_; }

  /// Calls fn(i, thread_index) for every i in [0, n), items handed out dynamically in chunks of
  /// `chunk`; thread_index is in [0, numThreads()). Returns when all calls have returned. An
  /// exception thrown by fn is rethrown here (the first one).
  void parallelFor(int n, const std::function<void(int, int)>& fn, int chunk = 1);
  /// The same with a fixed assignment: item i runs on thread i % numThreads(), each thread in
  /// increasing i. Per-thread sums are then independent of timing, so a reduction over threads
  /// in thread order is bit-for-bit repeatable (the backward pass uses it).
  void parallelForStatic(int n, const std::function<void(int, int)>& fn);

 private:
  void run(int n, const std::function<void(int, int)>& fn, int chunk, bool fixed);
  void workerLoop(int thread_index);
  void runItems(int thread_index);

  int num_threads_;
  ThreadPriority priority_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable start_cv_, done_cv_;
  const std::function<void(int, int)>* job_ = nullptr;
  int job_n_ = 0;
  int job_chunk_ = 1;
  bool job_static_ = false;
  std::atomic<int> next_{0};
  int busy_ = 0;
  long generation_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace dypho::mapping
