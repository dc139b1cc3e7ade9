/// MappingWorker: one thread, one ordered job queue with the documented full-queue policy.
#include "dypho/mapping/mapping_worker.h"

#include <algorithm>
#include <iterator>

#include "dypho/common/thread_budget.h"

namespace dypho::mapping {

MappingWorker::MappingWorker(std::size_t capacity, std::function<void(const MappingJob&)> handler,
                             std::function<bool()> idle_handler, ThreadPriority priority)
    : handler_(std::move(handler)),
      idle_handler_(std::move(idle_handler)),
      priority_(priority),
      capacity_(std::max<std::size_t>(1, capacity)) {
  thread_ = std::thread([this] { loop(); });
}

MappingWorker::~MappingWorker() { stop(); }

void MappingJob::merge(MappingJob&& later) {
  keyframes.insert(keyframes.end(), std::make_move_iterator(later.keyframes.begin()),
                   std::make_move_iterator(later.keyframes.end()));
  corrections.insert(corrections.end(), later.corrections.begin(), later.corrections.end());
}

bool MappingWorker::push(MappingJob job, bool block_when_full) {
  bool own_job = true;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    if (stop_) return false;
    if (block_when_full) {
      cv_.wait(lock, [&] { return stop_ || queue_.size() < capacity_; });
      if (stop_) return false;
    }
    if (!block_when_full && queue_.size() >= capacity_) {
      queue_.back().merge(std::move(job));  // in order: it would have run right after that one
      ++merged_;
      own_job = false;
    } else {
      queue_.push_back(std::move(job));
    }
    queued_ = queue_.size();
  }
  cv_.notify_all();
  return own_job;
}

void MappingWorker::loop() {
  nameCurrentThread("dypho_mapping");
  lowerCurrentThreadPriority(priority_);  // best effort: a failure only keeps the priority
  bool idle_work_left = true;
  for (;;) {
    MappingJob job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (idle_handler_ && idle_work_left && queue_.empty() && !stop_) {
        lock.unlock();
        idle_work_left = idle_handler_();  // one small step; a new job is taken right after it
        continue;
      }
      cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      idle_work_left = true;
      job = std::move(queue_.front());
      queue_.pop_front();
      queued_ = queue_.size();
      busy_ = true;
    }
    cv_.notify_all();  // room for a blocked producer
    handler_(job);     // the handler reports its own errors
    {
      std::lock_guard<std::mutex> lock(mutex_);
      busy_ = false;
    }
    cv_.notify_all();
  }
}

void MappingWorker::waitUntilIdle() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [&] { return stop_ || (queue_.empty() && !busy_); });
}

bool MappingWorker::stopping() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stop_;
}

void MappingWorker::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_.clear();
  queued_ = queue_.size();
}

void MappingWorker::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    queue_.clear();
    queued_ = queue_.size();
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::size_t MappingWorker::queued() const { return queued_; }

std::size_t MappingWorker::merged() const { return merged_; }

}  // namespace dypho::mapping
