#include "dypho/mapping/thread_pool.h"

#include <algorithm>

#include "dypho/common/thread_budget.h"

namespace dypho::mapping {

ThreadPool::ThreadPool(int num_threads, ThreadPriority priority)
    : num_threads_(std::max(1, num_threads)), priority_(priority) {
  for (int i = 1; i < num_threads_; ++i) workers_.emplace_back([this, i] { workerLoop(i); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  start_cv_.notify_all();
  for (auto& w : workers_) w.join();
}

void ThreadPool::runItems(int thread_index) {
  if (job_static_) {
    // Fixed assignment: item i on thread i % numThreads(), in increasing order.
    for (int i = thread_index; i < job_n_; i += num_threads_) {
      try {
        (*job_)(i, thread_index);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
        return;
      }
    }
    return;
  }
  for (;;) {
    const int begin = next_.fetch_add(job_chunk_);
    if (begin >= job_n_) break;
    const int end = std::min(job_n_, begin + job_chunk_);
    for (int i = begin; i < end; ++i) {
      try {
        (*job_)(i, thread_index);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
        next_.store(job_n_);
        return;
      }
    }
  }
}

void ThreadPool::workerLoop(int thread_index) {
  nameCurrentThread("dypho_pool_" + std::to_string(thread_index));
  lowerCurrentThreadPriority(priority_);  // best effort: a failure only keeps the priority
  long seen = 0;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      start_cv_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    runItems(thread_index);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      --busy_;
    }
    done_cv_.notify_one();
  }
}

void ThreadPool::parallelFor(int n, const std::function<void(int, int)>& fn, int chunk) {
  run(n, fn, chunk, /*fixed=*/false);
}

void ThreadPool::parallelForStatic(int n, const std::function<void(int, int)>& fn) { run(n, fn, 1, /*fixed=*/true); }

void ThreadPool::run(int n, const std::function<void(int, int)>& fn, int chunk, bool fixed) {
  if (n <= 0) return;
  if (workers_.empty() || n == 1) {
    for (int i = 0; i < n; ++i) fn(i, 0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    job_n_ = n;
    job_chunk_ = std::max(1, chunk);
    job_static_ = fixed;
    next_.store(0);
    busy_ = static_cast<int>(workers_.size());
    error_ = nullptr;
    ++generation_;
  }
  start_cv_.notify_all();
  runItems(0);
  std::unique_lock<std::mutex> lock(mutex_);
  done_cv_.wait(lock, [&] { return busy_ == 0; });
  job_ = nullptr;
  if (error_) std::rethrow_exception(error_);
}

}  // namespace dypho::mapping
