#pragma once
/// \file bounded_hand_over.h
/// A bounded queue between two threads. push() never blocks its producer: when the queue is full,
/// the oldest waiting item makes room and is handed back to the producer as dropped (like a ROS
/// subscriber queue). pushWhenRoom() instead waits for room (a producer that must not lose items
/// and may fall behind: its own input queue then does the dropping). The consumer takes items in
/// arrival order. Thread-safe.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>

namespace dypho {

template <typename T>
class BoundedHandOver {
 public:
  /// `capacity`: items that may wait [count], >= 1 (std::invalid_argument otherwise).
  explicit BoundedHandOver(std::size_t capacity) : capacity_(capacity) {
    if (capacity_ < 1) throw std::invalid_argument("BoundedHandOver: capacity must be >= 1");
  }

  /// Adds `item`. When `capacity` items were already waiting, the oldest is removed and returned
  /// (the caller counts it as dropped); otherwise nullopt. After close() the item itself is
  /// returned (nothing is taken any more).
  std::optional<T> push(T item) {
    std::optional<T> dropped;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (closed_) return std::optional<T>(std::move(item));
      if (items_.size() >= capacity_) {
        dropped.emplace(std::move(items_.front()));
        items_.pop_front();
      }
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
    return dropped;
  }

  /// Adds `item` once fewer than `capacity` items wait (waits for the consumer until then).
  /// Returns false, dropping `item`, when the queue is or gets closed meanwhile.
  bool pushWhenRoom(T item) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      room_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
      if (closed_) return false;
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
    return true;
  }

  /// Waits for the oldest waiting item; nullopt once closed and empty.
  std::optional<T> pop() {
    std::optional<T> item;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      ready_.wait(lock, [&] { return closed_ || !items_.empty(); });
      if (items_.empty()) return std::nullopt;
      item.emplace(std::move(items_.front()));
      items_.pop_front();
    }
    room_.notify_one();
    return item;
  }

  /// No more items will come: pop() returns what is still waiting, then nullopt.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
  }

  std::size_t capacity() const { return capacity_; }
  /// Items waiting now [count].
  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;  ///< an item or close() for pop()
  std::condition_variable room_;   ///< room or close() for pushWhenRoom()
  std::deque<T> items_;
  bool closed_ = false;
};

}  // namespace dypho
