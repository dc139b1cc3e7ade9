#include "dypho/mask/segment_scheduler.h"

#include <chrono>

#include <opencv2/imgproc.hpp>

#include "dypho/common/thread_budget.h"
#include "mask_internal.h"

namespace dypho {
namespace mask {

using internal::msSince;

SegmentScheduler::SegmentScheduler(const YoloOptions& options)
    : options_(options),
      segmenter_(std::make_unique<YoloSegmenter>(options)),
      backoff_(options.async_backoff_max_frames) {}

SegmentScheduler::~SegmentScheduler() {
  if (pending_.valid()) pending_.wait();
}

void SegmentScheduler::reset() {
  if (pending_.valid()) pending_.wait();
  pending_ = std::future<SegmentOutput>();
  flows_since_submit_.clear();
  frames_since_submit_ = 1 << 20;
  backoff_.reset();
  current_.release();
  current_boxes_.clear();
  current_age_ = 0;
}

void SegmentScheduler::carry(cv::Mat& mask, const cv::Mat& flow) {
  if (mask.empty() || flow.empty()) return;
  const double sx = static_cast<double>(mask.cols) / flow.cols;
  const double sy = static_cast<double>(mask.rows) / flow.rows;
  cv::resize(flow, flow_full_, mask.size(), 0, 0, cv::INTER_LINEAR);
  map_.create(mask.size(), CV_32FC2);
  for (int y = 0; y < mask.rows; ++y) {
    const cv::Vec2f* f = flow_full_.ptr<cv::Vec2f>(y);
    cv::Vec2f* m = map_.ptr<cv::Vec2f>(y);
    for (int x = 0; x < mask.cols; ++x) {
      m[x] = cv::Vec2f(static_cast<float>(x + f[x][0] * sx), static_cast<float>(y + f[x][1] * sy));
    }
  }
  cv::Mat carried;
  cv::remap(mask, carried, map_, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  mask = carried;
}

SegmentStep SegmentScheduler::step(const RgbdFrame& frame, const cv::Mat& backward_flow) {
  SegmentStep out;
  if (!segmenter_->ready()) return out;
  const auto t_carry = std::chrono::steady_clock::now();
  // Carry the current mask to this frame; remember the flow for a pending async result.
  if (!current_.empty() && current_.size() != frame.bgr.size()) current_.release();
  carry(current_, backward_flow);
  ++current_age_;
  if (pending_.valid()) flows_since_submit_.push_back(backward_flow.clone());
  out.carry_ms = msSince(t_carry);
  ++frames_since_submit_;
  backoff_.frameSeen();

  // Collect a finished async result and carry it over the frames since its input.
  if (pending_.valid() && pending_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    SegmentOutput r = pending_.get();
    const bool in_time = static_cast<int>(flows_since_submit_.size()) <= options_.max_age_frames;
    backoff_.resultArrived(in_time);
    out.late_result = !in_time;
    if (r.ok && r.mask.size() == frame.bgr.size()) {
      const auto t = std::chrono::steady_clock::now();
      current_ = r.mask;
      for (const cv::Mat& f : flows_since_submit_) carry(current_, f);
      current_age_ = static_cast<int>(flows_since_submit_.size());
      current_boxes_ = r.boxes_image;
      out.carry_ms += msSince(t);
    } else if (!r.ok) {
      out.message = r.message;
    }
    flows_since_submit_.clear();
  }

  if (!pending_.valid() && frames_since_submit_ >= options_.every_n_frames && frame.bgr.type() == CV_8UC3 &&
      (!options_.async || backoff_.mayStart())) {
    frames_since_submit_ = 0;
    out.network_started = true;
    if (options_.async) {
      // Copies: the caller may reuse its buffers while the worker runs.
      cv::Mat bgr = frame.bgr.clone(), depth = frame.depth_m.clone();
      YoloSegmenter* seg = segmenter_.get();
      const int nice = options_.async_nice;
      pending_ = std::async(std::launch::async, [seg, bgr, depth, nice] {
        nameCurrentThread("dypho_network");
        lowerCurrentThreadPriority({nice, /*idle_class=*/false});  // best effort: a failure only keeps the priority
        return seg->segment(bgr, depth);
      });
    } else {
      SegmentOutput r = segmenter_->segment(frame.bgr, frame.depth_m);
      out.network_ms = r.ms;
      if (r.ok) {
        current_ = r.mask;
        current_age_ = 0;
        current_boxes_ = r.boxes_image;
        out.fresh = true;
      } else {
        out.message = r.message;
      }
    }
  }
  // A mask carried too far is dropped (YoloOptions::max_age_frames): the flow-only mask judges the
  // frames until the next result.
  if (!current_.empty() && current_age_ > options_.max_age_frames) {
    current_.release();
    current_boxes_.clear();
    out.too_old = true;
  }
  out.network_wait_frames = backoff_.waitFrames();
  out.mask = current_;
  out.age_frames = current_age_;
  out.boxes_image = current_boxes_;
  out.num_detections = static_cast<int>(current_boxes_.size());
  return out;
}

}  // namespace mask
}  // namespace dypho
