#pragma once
/// \file bounded_queue.h
/// A thread-safe FIFO with a fixed capacity, used to hand work to a worker thread without ever
/// blocking the producer (a ROS callback): when full, the oldest item is dropped and counted.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>

namespace dypho {

template <typename T>
class BoundedQueue {
 public:
  /// capacity >= 1: the number of items held before the oldest is dropped.
  explicit BoundedQueue(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  /// Adds an item; returns false when an older item had to be dropped to make room.
  bool push(T item) {
    bool dropped = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (queue_.size() >= capacity_) {
        queue_.pop_front();
        ++num_dropped_;
        dropped = true;
      }
      queue_.push_back(std::move(item));
    }
    cv_.notify_one();
    return !dropped;
  }

  /// Blocks until an item is available or shutdown() was called (then returns nullopt).
  std::optional<T> pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return shutdown_ || !queue_.empty(); });
    if (queue_.empty()) return std::nullopt;
    T item = std::move(queue_.front());
    queue_.pop_front();
    return item;
  }

  /// Wakes every waiting pop(); later pops return the remaining items, then nullopt.
  void shutdown() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      shutdown_ = true;
    }
    cv_.notify_all();
  }

  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.clear();
  }

  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
  }

  /// Items dropped because the queue was full, since construction.
  std::size_t numDropped() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return num_dropped_;
  }

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<T> queue_;
  std::size_t num_dropped_ = 0;
  bool shutdown_ = false;
};

}  // namespace dypho
