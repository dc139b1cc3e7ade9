#pragma once
/// \file throttled_log.h
/// Throttling per kind of message, not per call site: ROS's *_THROTTLE macros would let the
/// first bad frame's reason hide a different problem that follows it within the period. The kind
/// of a message is its text without digits ("only 3 usable samples" and "only 5 usable samples"
/// are one kind); each kind is let through at most once per `period_s`.

#include <cctype>
#include <map>
#include <mutex>
#include <string>

#include <ros/time.h>

namespace dypho::ros_conversions {

class ThrottledLog {
 public:
  explicit ThrottledLog(double period_s = 5.0) : period_s_(period_s) {}

  /// True when `message` should be logged now.
  bool pass(const std::string& message) {
    std::string kind;
    for (char c : message) {
      if (!std::isdigit(static_cast<unsigned char>(c))) kind += c;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::WallTime now = ros::WallTime::now();
    auto it = last_.find(kind);
    if (it != last_.end() && (now - it->second).toSec() < period_s_) return false;
    if (last_.size() >= 64) last_.clear();  // bounded: a flood of new kinds starts over
    last_[kind] = now;
    return true;
  }

 private:
  double period_s_;
  std::mutex mutex_;
  std::map<std::string, ros::WallTime> last_;  ///< kind -> when it was last let through
};

}  // namespace dypho::ros_conversions
