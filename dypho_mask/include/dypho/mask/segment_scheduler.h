#pragma once
/// \file segment_scheduler.h
/// Runs the YOLO segmenter every N-th frame, synchronously or on a worker thread, and carries its
/// newest mask to every frame with the dense optical flow (mask_cur(x) = mask_old(x + flow(x)),
/// flow current -> previous), so the segment mask keeps up with the frame rate.

#include <future>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mask/yolo_segmenter.h"

namespace dypho {
namespace mask {

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

  /// Waits for a running network call, forgets every mask.
  void reset();

 private:
  void carry(cv::Mat& mask, const cv::Mat& backward_flow);

  YoloOptions options_;
  std::unique_ptr<YoloSegmenter> segmenter_;
  std::future<SegmentOutput> pending_;
  std::vector<cv::Mat> flows_since_submit_;  ///< flows of the frames after the pending input
  int frames_since_submit_ = 1 << 20;
  cv::Mat current_;  ///< newest mask carried to the last frame
  int current_age_ = 0;
  std::vector<cv::Rect> current_boxes_;
  cv::Mat map_, flow_full_;
};

}  // namespace mask
}  // namespace dypho
