/// MaskStage: the mask core with its motion prior, R_d hand-over and restart policy.
#include "dypho/mask/mask_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace dypho::mask {

MaskStage::MaskStage(const DynamicMaskOptions& options, const MaskStageOptions& stage)
    : stage_options_(stage), masker_(options), motion_(stage.motion_max_gap_s) {
  if (!(stage.previous_pose_wait_s >= 0.0 && stage.previous_pose_wait_s <= 1.0)) {
    throw std::invalid_argument("MaskStageOptions::previous_pose_wait_s must be in [0, 1] s, got " +
                                std::to_string(stage.previous_pose_wait_s));
  }
}

void MaskStage::observePose(const PoseUpdate& update) {
  {
    std::lock_guard<std::mutex> lock(prior_mutex_);
    motion_.observe(update);
    if (!newest_pose_ns_ || update.stamp_ns > *newest_pose_ns_) newest_pose_ns_ = update.stamp_ns;
  }
  pose_arrived_.notify_all();
}

bool MaskStage::waitForPreviousPose(std::unique_lock<std::mutex>& lock) {
  const Timestamp previous_ns = *previous_frame_ns_;
  const auto arrived = [&] { return newest_pose_ns_ && *newest_pose_ns_ >= previous_ns; };
  if (arrived()) return true;
  const auto wait = std::chrono::duration<double>(stage_options_.previous_pose_wait_s);
  return pose_arrived_.wait_for(lock, std::chrono::duration_cast<std::chrono::nanoseconds>(wait), arrived);
}

void MaskStage::observeMovingPoints(MovingPoints points) {
  std::lock_guard<std::mutex> lock(prior_mutex_);
  if (points.stamp_ns >= moving_points_.stamp_ns) moving_points_ = std::move(points);
}

void MaskStage::setPredictedDepth(Timestamp stamp_ns, cv::Mat depth_m) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1) return;
  std::lock_guard<std::mutex> lock(prior_mutex_);
  if (!rendered_depth_m_.empty()) ++stats_.rendered_depth_unmatched;  // superseded unused
  rendered_depth_m_ = std::move(depth_m);
  rendered_stamp_ns_ = stamp_ns;
  ++stats_.rendered_depth_offered;
}

bool MaskStage::wantsRenderedDepth() const {
  const BackgroundOptions& b = masker_.options().background;
  return b.enabled && b.tau > 0.0;
}

CameraIntrinsics MaskStage::workingCamera(const CameraIntrinsics& input) const {
  return scaledCamera(input, masker_.options().background.scale);  // the size of workingSize()
}

std::optional<Eigen::Isometry3d> MaskStage::poseAt(Timestamp stamp_ns) const {
  if (motion_.last() && stamp_ns == motion_.lastStamp()) return motion_.last();
  return motion_.predict(stamp_ns);
}

void MaskStage::fillPrior(const RgbdFrame& frame, MaskPrior* prior) {
  if (previous_frame_ns_) {
    const std::optional<Eigen::Isometry3d> T_world_prev = poseAt(*previous_frame_ns_);
    const std::optional<Eigen::Isometry3d> T_world_cur = poseAt(frame.stamp_ns);
    if (T_world_prev && T_world_cur) prior->T_prev_cur = T_world_prev->inverse() * *T_world_cur;
    // Fresh: the previous frame was tracked, and this frame is one interval after it.
    const Timestamp interval_ns = motion_.frameIntervalNs();
    const bool next_frame = interval_ns > 0 && frame.stamp_ns - *previous_frame_ns_ < interval_ns + interval_ns / 2;
    prior->prediction_fresh = motion_.last() && motion_.lastStamp() == *previous_frame_ns_ && next_frame;
    prior->after_gap = interval_ns > 0 && !next_frame;
    if (motion_.last() && interval_ns > 0) {
      const double behind = static_cast<double>(*previous_frame_ns_ - motion_.lastStamp()) / interval_ns;
      prior->pose_frames_behind = static_cast<int>(std::clamp(std::lround(behind), 0L, 1000L));
    }
  }
  if (!rendered_depth_m_.empty()) {
    const double offset_s = std::abs(timestampToSeconds(frame.stamp_ns - rendered_stamp_ns_));
    if (offset_s <= stage_options_.rendered_depth_tolerance_s) {
      prior->rendered_depth_m = rendered_depth_m_;
      rendered_depth_m_.release();
    } else if (rendered_stamp_ns_ < frame.stamp_ns) {
      rendered_depth_m_.release();  // rendered for an earlier frame: never used for this one
      ++stats_.rendered_depth_unmatched;
    }
  }
  if (!moving_points_.p_camera_m.empty() && moving_points_.stamp_ns < frame.stamp_ns &&
      timestampToSeconds(frame.stamp_ns - moving_points_.stamp_ns) <= stage_options_.moving_points_max_age_s) {
    const std::optional<Eigen::Isometry3d> T_world_seen = poseAt(moving_points_.stamp_ns);
    const std::optional<Eigen::Isometry3d> T_world_cur = poseAt(frame.stamp_ns);
    const Eigen::Isometry3f T_cur_seen = T_world_seen && T_world_cur
                                             ? (T_world_cur->inverse() * *T_world_seen).cast<float>()
                                             : Eigen::Isometry3f::Identity();
    prior->moving_points_camera_m.reserve(moving_points_.p_camera_m.size());
    for (const cv::Point3f& p : moving_points_.p_camera_m) {
      const Eigen::Vector3f q = T_cur_seen * Eigen::Vector3f(p.x, p.y, p.z);
      prior->moving_points_camera_m.emplace_back(q.x(), q.y(), q.z());
    }
  }
  previous_frame_ns_ = frame.stamp_ns;
}

MaskResult MaskStage::process(const RgbdFrame& frame, std::size_t frames_waiting) {
  std::lock_guard<std::mutex> process_lock(process_mutex_);
  MaskPrior prior;
  const int catch_up_from = masker_.options().catch_up_frames_waiting;
  prior.catching_up = catch_up_from > 0 && frames_waiting >= static_cast<std::size_t>(catch_up_from);
  bool restarted = false;
  {
    std::lock_guard<std::mutex> lock(prior_mutex_);
    const StampOrder order = stamp_gate_.admit(frame.stamp_ns);
    if (order == StampOrder::kRepeated || order == StampOrder::kLate) {
      ++stats_.dropped_out_of_order;
      MaskResult dropped;
      dropped.dropped = true;
      dropped.message = stamp_gate_.dropMessage(order);
      return dropped;
    }
    if (order == StampOrder::kJumpedBack) {
      motion_.reset();
      rendered_depth_m_.release();
      previous_frame_ns_.reset();
      newest_pose_ns_.reset();
      moving_points_ = MovingPoints();
      ++stats_.restarts;
      restarted = true;
    }
  }
  if (restarted) masker_.reset();
  // Live, and not behind: the flow first, then the previous frame's pose, which tracking hands
  // on meanwhile (usually a few milliseconds later).
  const bool wait = frames_waiting == 0 && stage_options_.previous_pose_wait_s > 0.0;
  if (wait) masker_.prepareFlow(frame, prior.catching_up);
  {
    std::unique_lock<std::mutex> lock(prior_mutex_);
    if (wait && previous_frame_ns_ && !waitForPreviousPose(lock)) ++stats_.pose_waits_timed_out;
    fillPrior(frame, &prior);
  }
  MaskResult result = masker_.compute(frame, prior);
  if (restarted) {
    result.message = "time jumped backwards (bag looped?): mask history restarted" +
                     std::string(result.message.empty() ? "" : "; ") + result.message;
  }
  std::lock_guard<std::mutex> lock(prior_mutex_);
  ++stats_.frames;
  if (prior.T_prev_cur) ++stats_.frames_with_ego_motion;
  if (result.rendered_depth_used) ++stats_.frames_with_rendered_depth;
  if (result.degraded) ++stats_.degraded_frames;
  if (prior.catching_up) ++stats_.frames_caught_up;
  if (prior.T_prev_cur && prior.prediction_fresh) ++stats_.frames_with_fresh_prior;
  if (prior.T_prev_cur && !prior.prediction_fresh && prior.pose_frames_behind == 1)
    ++stats_.frames_with_prior_one_behind;
  if (result.network_started) ++stats_.network_runs;
  if (result.network_result_late) ++stats_.network_results_late;
  if (!result.raw_segment_mask.empty()) ++stats_.frames_with_network_mask;
  return result;
}

void MaskStage::reset() {
  std::lock_guard<std::mutex> process_lock(process_mutex_);
  masker_.reset();
  std::lock_guard<std::mutex> lock(prior_mutex_);
  motion_.reset();
  previous_frame_ns_.reset();
  newest_pose_ns_.reset();
  stamp_gate_.reset();
  rendered_depth_m_.release();
  moving_points_ = MovingPoints();
  stats_ = MaskStageStats();
}

MaskStageStats MaskStage::stats() const {
  std::lock_guard<std::mutex> lock(prior_mutex_);
  return stats_;
}

}  // namespace dypho::mask
