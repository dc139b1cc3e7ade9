#pragma once
/// \file input_timing.h
/// How the camera frames reached a rostest's node compared with their stamps. A bag player
/// starved of CPU or disk falls behind its schedule, stops publishing /clock (rosbag publishes
/// the clock only while it waits for the next message) and then delivers the overdue frames in a
/// burst: the graph then sees more than 1x. Printing this beside a failure says whether the input
/// or the graph was late.

#include <algorithm>
#include <cstddef>
#include <mutex>
#include <sstream>
#include <string>

namespace dypho::test {

class InputTiming {
 public:
  /// `rate`: the player's rate (rosbag play -r); the schedule is the stamps' spacing / rate.
  explicit InputTiming(double rate = 1.0) : rate_(rate > 0.0 ? rate : 1.0) {}

  /// One frame: its stamp and the wall time it arrived [s]. Thread safe.
  void add(double stamp_s, double wall_s) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (frames_ == 0) {
      first_stamp_s_ = stamp_s;
      first_wall_s_ = wall_s;
    } else {
      // Lag behind the schedule the stamps set from the first frame on (0 when the frames arrive
      // at the player's rate).
      const double lag_s = (wall_s - first_wall_s_) - (stamp_s - first_stamp_s_) / rate_;
      max_lag_s_ = std::max(max_lag_s_, lag_s);
      if (lag_s > kLateS) ++late_frames_;
      max_gap_s_ = std::max(max_gap_s_, wall_s - last_wall_s_);
    }
    last_wall_s_ = wall_s;
    ++frames_;
  }

  /// "input: N frames; max lag behind the stamps' schedule L ms, K frames later than 100 ms,
  /// longest gap G ms".
  std::string describe() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::ostringstream os;
    os << "input: " << frames_ << " frames reached the test node; max lag behind their stamps' schedule at " << rate_
       << "x " << max_lag_s_ * 1e3 << " ms, " << late_frames_ << " frames more than " << kLateS * 1e3
       << " ms late, longest gap between frames " << max_gap_s_ * 1e3 << " ms";
    return os.str();
  }

 private:
  static constexpr double kLateS = 0.1;
  double rate_ = 1.0;
  mutable std::mutex mutex_;
  std::size_t frames_ = 0, late_frames_ = 0;
  double first_stamp_s_ = 0.0, first_wall_s_ = 0.0, last_wall_s_ = 0.0;
  double max_lag_s_ = 0.0, max_gap_s_ = 0.0;
};

}  // namespace dypho::test
