#pragma once
/// \file segment_scheduler.h
/// Runs the YOLO segmenter every N-th frame, synchronously or on a worker thread, and carries its
/// newest mask to every frame with the dense optical flow (mask_cur(x) = mask_old(x + flow(x)),
/// flow current -> previous), so the segment mask keeps up with the frame rate.

#include <algorithm>
#include <chrono>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mask/yolo_segmenter.h"

namespace dypho {
namespace mask {

/// How long an asynchronous network waits before its next run. A result that arrives older than
/// YoloOptions::max_age_frames is dropped unseen: the network is slower than the frames allow on
/// this machine, and every run of it takes CPU from the camera-rate mask and tracking threads.
/// Each such result doubles the wait after it (1, 2, 4, ... frames, up to a cap); each result in
/// time halves it, so a network that keeps up only now and then (a moment of low load) does not
/// go back to running flat out, and one that keeps up again (load gone) is back within a few runs.
class NetworkBackoff {
 public:
  /// `max_wait_frames` [frames]: the cap, >= 0; 0 = never wait (run whenever the last finished).
  explicit NetworkBackoff(int max_wait_frames) : max_wait_frames_(max_wait_frames) {}
  /// A result came back; `in_time`: young enough to be used.
  void resultArrived(bool in_time) {
    frames_since_result_ = 0;
    if (max_wait_frames_ <= 0) {
      wait_frames_ = 0;
    } else if (in_time) {
      wait_frames_ /= 2;
    } else {
      wait_frames_ = wait_frames_ <= 0 ? 1 : std::min(2 * wait_frames_, max_wait_frames_);
    }
  }
  /// One more frame seen since the last result.
  void frameSeen() { ++frames_since_result_; }
  /// True when the network may run again (its last result is at least the wait old).
  bool mayStart() const { return frames_since_result_ >= wait_frames_; }
  /// Frames the next run waits after a result [frames].
  int waitFrames() const { return wait_frames_; }
  void reset() {
    wait_frames_ = 0;
    frames_since_result_ = 0;
  }

 private:
  int max_wait_frames_;
  int wait_frames_ = 0;
  int frames_since_result_ = 0;
};

/// What the scheduler did for a frame.
struct SegmentStep {
  cv::Mat mask;        ///< CV_8UC1 image size, 255 = dynamic class; empty = no segment mask yet
  bool fresh = false;  ///< a network result for THIS frame (not carried)
  int age_frames = 0;  ///< frames between the network's input and this frame
  /// The newest mask became older than YoloOptions::max_age_frames on this frame and was dropped
  /// (`mask` is empty from here until the next result).
  bool too_old = false;
  int num_detections = 0;             ///< detections of the result in use
  std::vector<cv::Rect> boxes_image;  ///< their boxes (image px, of the frame they were found in)
  double network_ms = 0.0;            ///< network time spent inside this call (0 when async or not run) [ms]
  double carry_ms = 0.0;              ///< time spent carrying masks with the flow [ms]
  bool network_started = false;       ///< the network was started (async) or run (sync) on this frame
  bool late_result = false;           ///< an async result came back on this frame already too old to use
  int network_wait_frames = 0;        ///< frames the async network now waits after a result (NetworkBackoff)
  std::string message;                ///< a network error of this frame, if any
};

class SegmentScheduler {
 public:
  explicit SegmentScheduler(const YoloOptions& options);
  ~SegmentScheduler();
  SegmentScheduler(const SegmentScheduler&) = delete;
  SegmentScheduler& operator=(const SegmentScheduler&) = delete;

  bool ready() const { return segmenter_->ready(); }
  const std::string& status() const { return segmenter_->status(); }

  /// Call once per frame. `backward_flow`: flow of this frame to the previous one at reduced
  /// resolution [flow px] (CV_32FC2), empty when none (then masks are carried unchanged).
  SegmentStep step(const RgbdFrame& frame, const cv::Mat& backward_flow);

  /// True while an asynchronous network run has not finished (its result is collected by the
  /// first step() after it has).
  bool networkBusy() const {
    return pending_.valid() && pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready;
  }

  /// Waits for a running network call, forgets every mask.
  void reset();

 private:
  void carry(cv::Mat& mask, const cv::Mat& backward_flow);

  YoloOptions options_;
  std::unique_ptr<YoloSegmenter> segmenter_;
  std::future<SegmentOutput> pending_;
  NetworkBackoff backoff_;
  std::vector<cv::Mat> flows_since_submit_;  ///< flows of the frames after the pending input
  int frames_since_submit_ = 1 << 20;
  cv::Mat current_;  ///< newest mask carried to the last frame
  int current_age_ = 0;
  std::vector<cv::Rect> current_boxes_;
  cv::Mat map_, flow_full_;
};

}  // namespace mask
}  // namespace dypho
