/// TrackingStage: the tracker with its trajectory, restart rule and hand-over to the other stages.
#include "dypho/tracking/tracking_stage.h"

#include <algorithm>
#include <limits>
#include <string>

#include "dypho/common/trajectory_io.h"

namespace dypho::tracking {

TrackingStage::TrackingStage(const TrackingOptions& options) : odometry_(options) {}

TrackingOutput TrackingStage::process(const RgbdFrame& frame, const cv::Mat& mask, MaskJudgement judgement,
                                      const PreparedFeatures* prepared, int frames_waiting) {
  std::lock_guard<std::mutex> lock(mutex_);
  TrackingOutput out;
  const StampOrder order = stamp_gate_.admit(frame.stamp_ns);
  if (order == StampOrder::kRepeated || order == StampOrder::kLate) {
    out.dropped = true;
    out.result.stamp_ns = frame.stamp_ns;
    out.result.message = stamp_gate_.dropMessage(order);
    out.pose.stamp_ns = frame.stamp_ns;
    out.pose.T_world_camera.matrix().setConstant(std::numeric_limits<double>::quiet_NaN());
    return out;
  }
  if (order == StampOrder::kJumpedBack) {
    recorder_.clear();  // the tracker resets itself on this frame (RgbdOdometry::track)
    out.restarted = true;
    odom_.reset();
    if (localization_session_) {  // the loaded map stays: searched again from this frame
      restoreLocked(*localization_session_);
      out.session_event = "time jumped backwards: the loaded map is kept (localization_only), searching it again";
    }
  }
  if (pending_session_) out.session_event = restorePending(frame.camera);
  out.result = odometry_.track(frame, mask, judgement, prepared, frames_waiting);
  if (out.result.state == TrackingState::kOk) awaiting_first_pose_ = false;
  if (!awaiting_first_pose_) recorder_.add(out.result);
  const TrackingResult& r = out.result;
  out.pose.stamp_ns = r.stamp_ns;
  out.pose.T_world_camera = r.T_world_camera;
  out.pose.trusted = r.state == TrackingState::kOk && r.T_world_camera.matrix().allFinite();
  out.pose.anchored = r.anchored;
  out.pose.discontinuous = r.discontinuous || out.restarted;
  out.pose.restarted = out.restarted;
  out.pose.T_correction = r.T_correction;
  if (out.pose.trusted && out.pose.anchored) {
    // Loop closures are in the tracker's odometry frame already; other jumps go into map -> odom.
    const bool jumped = r.relocalized || (r.discontinuous && !r.loop_closed);
    out.T_map_odom = odom_.update(r.T_world_camera, r.T_world_odom, jumped);
  }
  return out;
}

RunEnd TrackingStage::finishRun() {
  std::lock_guard<std::mutex> lock(mutex_);
  RunEnd end = odometry_.finishRun();
  end.frame_refinement = odometry_.refineRecordedPoses(recorder_.mutableRecords());
  return end;
}

std::size_t TrackingStage::adoptKeyframePoses(const KeyframePoseCorrections& T_world_keyframe) {
  std::lock_guard<std::mutex> lock(mutex_);
  return odometry_.adoptKeyframePoses(T_world_keyframe);
}

PoseList TrackingStage::finalTrajectory() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return recorder_.finalPoses(odometry_.map(), positionSmoothing(odometry_.options()));
}

PoseList TrackingStage::onlineTrajectory() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return recorder_.onlinePoses();
}

PoseList TrackingStage::trackedPath(std::size_t max_poses) const {
  std::lock_guard<std::mutex> lock(mutex_);
  // Only the newest records the path can show (and the fit's window before them) are
  // re-expressed and fitted, under the mutex tracking waits on: the cost stays bounded by
  // max_poses on a long run (fitting an hour at 30 Hz took 28 ms).
  const std::vector<RecordedPose>& records = recorder_.records();
  constexpr std::size_t kFitMarginRecords = 64;
  const std::size_t shown = max_poses + kFitMarginRecords;
  const std::size_t first = records.size() > shown ? records.size() - shown : 0;
  const PoseList tail = recorder_.finalPoses(odometry_.map(), positionSmoothing(odometry_.options()), first);
  PoseList path;
  for (std::size_t i = 0; i < tail.size() && first + i < records.size(); ++i) {
    if (records[first + i].reference_keyframe_id >= 0) path.push_back(tail[i]);
  }
  if (path.size() > max_poses) path.erase(path.begin(), path.end() - static_cast<std::ptrdiff_t>(max_poses));
  return path;
}

PoseList TrackingStage::keyframePoses() const {
  std::lock_guard<std::mutex> lock(mutex_);
  PoseList poses;
  for (const auto& [id, keyframe] : odometry_.map().keyframes())
    poses.emplace_back(keyframe.stamp_ns, keyframe.T_world_camera);
  std::sort(poses.begin(), poses.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return poses;
}

std::size_t TrackingStage::numFrames() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return recorder_.records().size();
}

std::vector<std::string> TrackingStage::saveTrajectories(const std::string& dir) const {
  const std::vector<std::string> paths{dir + "/trajectory.txt", dir + "/trajectory_online.txt", dir + "/keyframes.txt"};
  writeTumTrajectory(paths[0], toStampedPoses(finalTrajectory()));
  writeTumTrajectory(paths[1], toStampedPoses(onlineTrajectory()));
  writeTumTrajectory(paths[2], toStampedPoses(keyframePoses()));
  return paths;
}

TrackerSession TrackingStage::session() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return odometry_.session();
}

void TrackingStage::restoreSession(TrackerSession session) {
  std::lock_guard<std::mutex> lock(mutex_);
  restoreLocked(std::move(session));
}

void TrackingStage::restoreLocked(TrackerSession session) {
  std::optional<TrackerSession> kept;
  if (options().localization_only) kept = session;
  odometry_.restoreSession(std::move(session));  // throws before changing anything
  recorder_.clear();
  stamp_gate_.reset();
  awaiting_first_pose_ = true;
  odom_.reset();
  if (kept) localization_session_ = std::move(kept);
}

void TrackingStage::restoreSessionAtNextFrame(TrackerSession session) {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_session_ = std::move(session);
}

std::string TrackingStage::restorePending(const CameraIntrinsics& camera) {
  TrackerSession session = std::move(*pending_session_);
  pending_session_.reset();
  const std::string mismatch = cameraMismatch(session.camera, camera);
  if (!mismatch.empty()) {
    return "the session to restore is for another camera than this frame's (" + mismatch + "): not restored";
  }
  const std::size_t keyframes = session.map.keyframes.size();
  try {
    restoreLocked(std::move(session));
  } catch (const std::invalid_argument& e) {
    return std::string("the session cannot be restored: ") + e.what();
  }
  return "session restored (" + std::to_string(keyframes) + " keyframes): searching the loaded map";
}

void TrackingStage::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  odometry_.reset();
  recorder_.clear();
  stamp_gate_.reset();
  awaiting_first_pose_ = false;
  pending_session_.reset();
  localization_session_.reset();
  odom_.reset();
}

std::size_t TrackingStage::droppedOutOfOrder() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stamp_gate_.dropped();
}

}  // namespace dypho::tracking
