#pragma once
/// \file sync_watchdog.h
/// Warns when a synchronised input set has not arrived for a while, naming the topics expected.

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include <ros/ros.h>

namespace dypho::ros_conversions {

class SyncWatchdog {
 public:
  /// Starts a timer on `nh` that warns (through ROS_WARN with the nodelet's name) every
  /// `timeout_s` seconds while no set was received. `topics` are the resolved topic names;
  /// `has_approx_sync`: the nodelet has an ~approx_sync parameter to suggest (else only
  /// ~queue_size is suggested).
  SyncWatchdog(ros::NodeHandle& nh, const std::string& name, std::vector<std::string> topics, double timeout_s,
               bool has_approx_sync)
      : name_(name), topics_(std::move(topics)), timeout_s_(timeout_s), has_approx_sync_(has_approx_sync) {
    if (timeout_s_ > 0.0) {
      timer_ = nh.createWallTimer(ros::WallDuration(timeout_s_), [this](const ros::WallTimerEvent&) { check(); });
    }
  }

  /// Call from the synchronised callback.
  void tick() { last_ns_.store(ros::WallTime::now().toNSec()); }

 private:
  void check() const {
    const std::int64_t last_ns = last_ns_.load();
    if (last_ns > 0 && (ros::WallTime::now().toNSec() - last_ns) * 1e-9 < timeout_s_) return;
    std::string list;
    for (const auto& t : topics_) list += "\n  " + t;
    ROS_WARN_STREAM("[" << name_ << "] no synchronised input for " << timeout_s_ << " s. Waiting for:" << list
                        << "\nCheck the topics with 'rostopic hz', the remaps in the launch file, "
                        << (has_approx_sync_ ? "and raise ~queue_size or set ~approx_sync true if stamps differ."
                                             : "and raise ~queue_size if the stamps of the inputs differ a lot."));
  }

  std::string name_;
  std::vector<std::string> topics_;
  double timeout_s_;
  bool has_approx_sync_ = false;
  ros::WallTimer timer_;
  std::atomic<std::int64_t> last_ns_{0};  // wall time of the last set [ns]; 0 = none yet
};

}  // namespace dypho::ros_conversions
