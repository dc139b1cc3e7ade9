/// MappingWorker: one thread, one ordered job queue with the documented full-queue policy.
#include "dypho/mapping/mapping_worker.h"

#include <algorithm>

namespace dypho::mapping {

MappingWorker::MappingWorker(std::size_t capacity, std::function<void(const MappingJob&)> handler)
    : handler_(std::move(handler)), capacity_(std::max<std::size_t>(1, capacity)) {
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
      const auto oldest = std::find_if(queue_.begin(), queue_.end(), [](const MappingJob& j) { return j.keyframe != nullptr; });
      if (oldest != queue_.end()) {
        if (oldest->corrections.empty()) {
          queue_.erase(oldest);
        } else {
          oldest->keyframe.reset();  // keep its corrections
        }
        ++dropped_;
        kept_all = false;
      }
    }
    queue_.push_back(std::move(job));
  }
  cv_.notify_all();
  return kept_all;
}

void MappingWorker::loop() {
  for (;;) {
    MappingJob job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
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
}

void MappingWorker::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    queue_.clear();
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::size_t MappingWorker::queued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

std::size_t MappingWorker::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

}  // namespace dypho::mapping
