/// SlamPipeline: the three stages chained with direct calls.
#include "dypho/pipeline/slam_pipeline.h"

#include <chrono>

namespace dypho::pipeline {
namespace {

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

/// The mask stage's options: no wait for a pose that PipelineOptions::mask_poses_one_frame_late
/// holds back until after the mask.
mask::MaskStageOptions maskStageOptions(const PipelineOptions& options) {
  mask::MaskStageOptions stage = options.mask_stage;
  if (options.mask_poses_one_frame_late) stage.previous_pose_wait_s = 0.0;
  return stage;
}

}  // namespace

SlamPipeline::SlamPipeline(const PipelineOptions& options, mapping::MappingMode mode)
    : options_(options),
      mask_(options.mask, maskStageOptions(options)),
      tracking_(options.tracking),
      mapping_(options.mapping, mode, options.mapping_stage) {}

void SlamPipeline::handLatePoseToMask() {
  if (!late_pose_) return;
  mask_.observeMovingPoints(std::move(late_pose_->moving_points));
  mask_.observePose(late_pose_->pose);
  late_pose_.reset();
}

bool SlamPipeline::mapsFrames() const { return options_.build_map && !options_.tracking.localization_only; }

bool SlamPipeline::wantsRenderedDepth() const {
  return options_.mask_source == MaskSource::kFlow && mask_.wantsRenderedDepth();
}

FrameReport SlamPipeline::process(const RgbdFrame& frame, const cv::Mat& external_mask) {
  return trackFrame(maskFrame(frame, external_mask));
}

MaskedFrame SlamPipeline::maskFrame(const RgbdFrame& frame, const cv::Mat& external_mask, std::size_t frames_waiting) {
  MaskedFrame out;
  out.frame = frame;
  FrameReport& report = out.report;
  if (wantsRenderedDepth() && frame.camera.valid()) {
    const auto t_render = std::chrono::steady_clock::now();
    cv::Mat rendered = mapping_.predictedDepth(frame.stamp_ns, mask_.workingCamera(frame.camera));
    if (!rendered.empty()) mask_.setPredictedDepth(frame.stamp_ns, std::move(rendered));
    report.render_ms = msSince(t_render);
  }
  const auto t_mask = std::chrono::steady_clock::now();
  if (options_.mask_source == MaskSource::kFlow) {
    const mask::MaskResult result = mask_.process(frame, frames_waiting);
    handLatePoseToMask();
    if (result.dropped) {
      report.dropped = true;
      report.message = result.message;
      report.tracking.stamp_ns = frame.stamp_ns;
      return out;
    }
    out.mask = result.mask;
    out.judgement = result.unjudged ? tracking::MaskJudgement::kUnjudged : tracking::MaskJudgement::kJudged;
    report.masked_fraction = result.masked_fraction;
    report.mask_degraded = result.degraded;
    report.rendered_depth_used = result.rendered_depth_used;
  } else if (options_.mask_source == MaskSource::kExternal && !external_mask.empty()) {
    out.mask = external_mask;
    out.judgement = tracking::MaskJudgement::kJudged;
    report.masked_fraction = static_cast<double>(cv::countNonZero(out.mask)) / static_cast<double>(out.mask.total());
  }
  report.mask_ms = msSince(t_mask);
  return out;
}

FrameReport SlamPipeline::trackFrame(MaskedFrame masked) {
  FrameReport report = std::move(masked.report);
  if (report.dropped) return report;
  return handOnTracked(tracking_.process(masked.frame, masked.mask, masked.judgement), std::move(report));
}

FrameReport SlamPipeline::handOnTracked(tracking::TrackingOutput out, FrameReport report) {
  if (out.dropped) {
    report.dropped = true;
    report.message = out.result.message;
    report.tracking = std::move(out.result);
    return report;
  }
  // The points before the pose: a mask waiting for this pose (live) starts when it arrives.
  MovingPoints moving_points{out.result.stamp_ns, out.result.moving_points_camera_m};
  if (options_.mask_poses_one_frame_late) {
    late_pose_ = LatePose{out.pose, std::move(moving_points)};
  } else {
    mask_.observeMovingPoints(std::move(moving_points));
    mask_.observePose(out.pose);
  }
  if (options_.build_map) mapping_.observePose(out.pose);
  if (mapsFrames()) {
    const auto t_map = std::chrono::steady_clock::now();
    mapping_.correctKeyframes(out.corrections());
    // A keyframe at an untrusted pose (re-initialised, not yet anchored) would corrupt the map.
    if (out.result.keyframe && out.pose.trusted && out.pose.anchored) mapping_.addKeyframe(out.result.keyframe);
    report.mapping_ms = msSince(t_map);
  }
  report.tracking = std::move(out.result);
  return report;
}

tracking::RunEnd SlamPipeline::finishTracking() {
  tracking::RunEnd end = tracking_.finishRun();
  if (mapsFrames()) mapping_.correctKeyframes(end.corrected_keyframes);
  return end;
}

std::size_t SlamPipeline::adoptMapKeyframePoses() {
  if (!mapsFrames() || !mapping_.gaussians().options().pose_refinement) return 0;
  mapping_.finish();
  return tracking_.adoptKeyframePoses(mapping_.gaussians().keyframePoses());
}

}  // namespace dypho::pipeline
