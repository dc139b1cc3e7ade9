#pragma once
/// \file rolling_stats.h
/// The monotonic clock in seconds, percentiles of the newest samples of a quantity (stage
/// latencies for diagnostics) and the rate of events over a time window (input rate). The classes
/// are not thread-safe: one owner, or the owner's lock.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <deque>
#include <vector>

namespace dypho {

/// Seconds of the monotonic clock (arrival times, rates, waits of the live figures).
inline double steadyClockSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// The newest `capacity` samples; percentile() over them.
class RollingSamples {
 public:
  explicit RollingSamples(std::size_t capacity = 300) : capacity_(std::max<std::size_t>(1, capacity)) {}

  void add(double value) {
    if (!std::isfinite(value)) return;
    samples_.push_back(value);
    if (samples_.size() > capacity_) samples_.pop_front();
  }
  /// The q-quantile (q in [0, 1], nearest rank) of the samples held; 0 when there are none.
  double percentile(double q) const {
    if (samples_.empty()) return 0.0;
    std::vector<double> sorted(samples_.begin(), samples_.end());
    const double clamped = std::min(1.0, std::max(0.0, q));
    const auto rank = static_cast<std::size_t>(std::ceil(clamped * static_cast<double>(sorted.size())));
    const std::size_t index = rank == 0 ? 0 : rank - 1;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(index), sorted.end());
    return sorted[index];
  }
  std::size_t size() const { return samples_.size(); }
  void clear() { samples_.clear(); }

 private:
  std::size_t capacity_;
  std::deque<double> samples_;
};

/// Events per second over the last `window_s` seconds of a monotonic clock.
class EventRate {
 public:
  explicit EventRate(double window_s = 5.0) : window_s_(window_s > 0 ? window_s : 5.0) {}

  void add(double now_s) {
    times_.push_back(now_s);
    trim(now_s);
  }
  /// Events per second: (events - 1) over the span they cover; 0 with fewer than two events.
  double rateHz(double now_s) {
    trim(now_s);
    if (times_.size() < 2) return 0.0;
    const double span = times_.back() - times_.front();
    return span > 0 ? static_cast<double>(times_.size() - 1) / span : 0.0;
  }
  void clear() { times_.clear(); }

 private:
  void trim(double now_s) {
    while (!times_.empty() && times_.front() < now_s - window_s_) times_.pop_front();
  }
  double window_s_;
  std::deque<double> times_;
};

}  // namespace dypho
