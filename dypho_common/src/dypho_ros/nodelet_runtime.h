#pragma once
/// \file nodelet_runtime.h
/// What every nodelet of the package does the same way around its stage:
///  - start-up (startOrStayIdle): per-frame buffers kept in the process, then the nodelet's
///    start(); a bad parameter must not take the manager down, nor vanish: it is logged as FATAL
///    with the reason and the nodelet stays idle (nothing advertised or subscribed) until it is
///    restarted with a fixed configuration;
///  - /diagnostics (NodeletDiagnostics): one task under the project's hardware id, updated on a
///    wall timer;
///  - shutdown (saveOnShutdown): the outputs written once more, unless nothing was processed (a
///    run stopped before its first frame must not replace the last run's files with nothing),
///    and a failure logged instead of thrown out of a destructor.
/// The order of a nodelet's destructor: stop the diagnostics (their task reads the stage), stop
/// the nodelet's threads, then saveOnShutdown.

#include <exception>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>

#include "dypho/common/frame_allocator.h"

namespace dypho::ros_conversions {

/// Runs `start` (the nodelet's parameters, stage, publications and subscriptions). Logs under
/// the nodelet's `name`; returns false when start-up failed and the nodelet stays idle.
inline bool startOrStayIdle(const std::string& name, const std::function<void()>& start) {
  // Per-frame buffers stay in the manager's heaps instead of being faulted in every frame.
  if (const std::string why = keepFrameBuffersInProcess(); !why.empty()) ROS_DEBUG_STREAM_NAMED(name, why);
  try {
    start();
    return true;
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM_NAMED(
        name, "not started: " << e.what() << " (this nodelet stays idle; fix the configuration and restart it)");
    return false;
  }
}

/// /diagnostics of one nodelet: `task` (named `task_name`) reported under hardware id
/// "dypho_slam" every `period_s` [s] (default 0.5) of wall time.
class NodeletDiagnostics {
 public:
  using Task = std::function<void(diagnostic_updater::DiagnosticStatusWrapper&)>;

  NodeletDiagnostics(ros::NodeHandle& nh, ros::NodeHandle& pnh, const std::string& nodelet_name,
                     const std::string& task_name, Task task, double period_s = 0.5)
      : updater_(nh, pnh, nodelet_name), task_(std::move(task)) {
    updater_.setHardwareID("dypho_slam");
    updater_.add(task_name, [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { task_(stat); });
    timer_ = nh.createWallTimer(ros::WallDuration(period_s), [this](const ros::WallTimerEvent&) { updater_.update(); });
  }
  ~NodeletDiagnostics() { stop(); }
  NodeletDiagnostics(const NodeletDiagnostics&) = delete;
  NodeletDiagnostics& operator=(const NodeletDiagnostics&) = delete;

  /// No report after this returns: first in the nodelet's destructor.
  void stop() { timer_.stop(); }

 private:
  diagnostic_updater::Updater updater_;
  Task task_;
  ros::WallTimer timer_;
};

/// The shutdown save: nothing when `nothing_processed` (said in the log, naming `output_dir`),
/// else `save()` (which logs what it wrote); an exception is logged as an error.
inline void saveOnShutdown(const std::string& name, const std::string& output_dir, bool nothing_processed,
                           const std::string& nothing_what, const std::function<void()>& save) {
  if (output_dir.empty()) return;  // empty only when start-up failed before it was resolved
  if (nothing_processed) {
    ROS_INFO_STREAM_NAMED(name, nothing_what << ": nothing written to " << output_dir);
    return;
  }
  try {
    save();
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM_NAMED(name, "could not write the outputs on shutdown: " << e.what());
  }
}

/// Services on a callback queue and thread of their own instead of the manager's: for a service
/// that calls another nodelet's service (which needs a manager thread) and so must not hold one
/// (the session services). Advertise, then start(); stop() before what the callbacks use goes.
class OwnThreadServices {
 public:
  explicit OwnThreadServices(const ros::NodeHandle& private_nh) : nh_(private_nh) { nh_.setCallbackQueue(&queue_); }
  ~OwnThreadServices() { stop(); }
  OwnThreadServices(const OwnThreadServices&) = delete;
  OwnThreadServices& operator=(const OwnThreadServices&) = delete;

  template <class Owner, class Request, class Response>
  void advertise(const std::string& name, bool (Owner::*callback)(Request&, Response&), Owner* owner) {
    servers_.push_back(nh_.advertiseService(name, callback, owner));
  }
  void start() { spinner_.start(); }
  /// Waits for a running callback to return.
  void stop() { spinner_.stop(); }

 private:
  ros::CallbackQueue queue_;
  ros::NodeHandle nh_;
  std::vector<ros::ServiceServer> servers_;
  ros::AsyncSpinner spinner_{1, &queue_};
};

}  // namespace dypho::ros_conversions
