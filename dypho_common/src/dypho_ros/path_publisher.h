#pragma once
/// \file path_publisher.h
/// A nav_msgs/Path of the newest poses, published from a wall timer at most once per period and
/// only when it changed: a path of thousands of poses is too large to send with every frame.

#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>

namespace dypho::ros_conversions {

class ThrottledPathPublisher {
 public:
  /// Advertises `topic` on `nh` (latched) in `frame_id`; keeps the newest `max_poses` (>= 1)
  /// poses and publishes every `period_s` (> 0) seconds when they changed.
  ThrottledPathPublisher(ros::NodeHandle& nh, const std::string& topic, const std::string& frame_id, int max_poses,
                         double period_s)
      : max_poses_(static_cast<std::size_t>(max_poses)) {
    path_.header.frame_id = frame_id;
    pub_ = nh.advertise<nav_msgs::Path>(topic, 2, true);
    timer_ =
        nh.createWallTimer(ros::WallDuration(period_s), [this](const ros::WallTimerEvent&) { publishIfChanged(); });
  }
  ~ThrottledPathPublisher() { timer_.stop(); }
  ThrottledPathPublisher(const ThrottledPathPublisher&) = delete;
  ThrottledPathPublisher& operator=(const ThrottledPathPublisher&) = delete;

  /// Adds `pose` (in the path's frame) as the newest, dropping the oldest beyond max_poses.
  void append(const geometry_msgs::PoseStamped& pose) {
    std::lock_guard<std::mutex> lock(mutex_);
    path_.header.stamp = pose.header.stamp;
    path_.poses.push_back(pose);
    if (path_.poses.size() > max_poses_) path_.poses.erase(path_.poses.begin());
    changed_ = true;
  }

  /// Replaces the whole path (poses oldest first; the newest max_poses are kept), stamped `stamp`.
  void replace(std::vector<geometry_msgs::PoseStamped> poses, const ros::Time& stamp) {
    if (poses.size() > max_poses_) poses.erase(poses.begin(), poses.end() - static_cast<std::ptrdiff_t>(max_poses_));
    std::lock_guard<std::mutex> lock(mutex_);
    path_.header.stamp = stamp;
    path_.poses = std::move(poses);
    changed_ = true;
  }

  /// Stops the timer: nothing is published from now on (a nodelet shutting down).
  void stopPublishing() { timer_.stop(); }

  /// Empties the path (published as empty at the next tick).
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    path_.poses.clear();
    changed_ = true;
  }

 private:
  void publishIfChanged() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!changed_) return;
    changed_ = false;
    pub_.publish(path_);
  }

  std::size_t max_poses_;
  std::mutex mutex_;  ///< guards path_ and changed_
  nav_msgs::Path path_;
  bool changed_ = false;
  ros::Publisher pub_;
  ros::WallTimer timer_;  ///< last: stopped and destroyed before what its callback uses
};

}  // namespace dypho::ros_conversions
