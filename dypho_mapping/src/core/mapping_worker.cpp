/// MappingWorker: one thread, one ordered job queue with the documented full-queue policy.
#include "dypho/mapping/mapping_worker.h"

#include <algorithm>

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

bool MappingWorker::push(MappingJob job, bool block_when_full) {
  bool kept_all = true;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    if (stop_) return false;
    if (block_when_full) {
      cv_.wait(lock, [&] { return stop_ || queue_.size() < capacity_; });
      if (stop_) return false;
    } else if (queue_.size() >= capacity_ && job.keyframe) {
      const auto oldest =
          std::find_if(queue_.begin(), queue_.end(), [](const MappingJob& j) { return j.keyframe != nullptr; });
      if (oldest != queue_.end()) {
        if (oldest->corrections.empty()) {
          queue_.erase(oldest);
          queued_ = queue_.size();
        } else {
          oldest->keyframe.reset();  // keep its corrections
        }
        ++dropped_;
        kept_all = false;
      }
    }
    queue_.push_back(std::move(job));
    queued_ = queue_.size();
  }
  cv_.notify_all();
  return kept_all;
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

std::size_t MappingWorker::dropped() const { return dropped_; }

}  // namespace dypho::mapping
