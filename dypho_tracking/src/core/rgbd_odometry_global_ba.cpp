/// RgbdOdometry's global bundle adjustment: after a loop and at the end of a run.
#include <algorithm>
#include <optional>

#include "dypho/tracking/rgbd_odometry.h"

namespace dypho {
namespace tracking {

std::set<std::int64_t> RgbdOdometry::globalBaExtraFixed() const {
  std::set<std::int64_t> fixed;
  if (unanchored_from_keyframe_id_ < 0) return fixed;
  // The segment's first keyframe still in the map (culling may have removed the very first).
  const auto first = map_.keyframes().lower_bound(unanchored_from_keyframe_id_);
  if (first != map_.keyframes().end()) fixed.insert(first->first);
  return fixed;
}

GlobalBaResult RgbdOdometry::runGlobalBa() {
  GlobalBaResult result;
  if (!has_pinhole_) {
    result.message = "no keyframe yet";
  } else {
    result = global_ba_.adjust(&map_, pinhole_, globalBaExtraFixed());
  }
  global_ba_stats_.last = result;
  return result;
}

void RgbdOdometry::globalBaAfterLoop(std::int64_t keyframe_id, TrackingResult* result) {
  if (!options_.global_ba_after_loop) return;
  const std::optional<Eigen::Isometry3d> T_world_keyframe_before = map_.keyframePose(keyframe_id);
  const GlobalBaResult ba = runGlobalBa();
  if (!ba.ran) {
    result->message += "; global BA not run: " + ba.message;
    return;
  }
  ++global_ba_stats_.after_loop_runs;
  global_ba_stats_.after_loop_total_ms += ba.time_ms;
  global_ba_stats_.after_loop_max_ms = std::max(global_ba_stats_.after_loop_max_ms, ba.time_ms);
  // The odometry frame's correction is the loop's: the global BA after it is part of it.
  const std::optional<Eigen::Isometry3d> T_world_keyframe_after = map_.keyframePose(keyframe_id);
  if (T_world_keyframe_before && T_world_keyframe_after) {
    T_world_odom_ = *T_world_keyframe_after * T_world_keyframe_before->inverse() * T_world_odom_;
  }
  // Points were removed (outliers) and moved: the views are rebuilt before the next matching.
  views_stale_ = true;
  result->message += "; global BA " + describe(ba);
}

RunEnd RgbdOdometry::finishRun() {
  RunEnd end;
  TrackingResult scratch;  // collects the corrections and the last pose's correction
  if (pending_ba_.valid() && has_pinhole_) finishLocalBa(pinhole_, &scratch);
  if (options_.localization_only) {
    end.global_ba.message = "off (localization_only: the loaded map is not changed)";
  } else if (!options_.global_ba_at_end) {
    end.global_ba.message = "off (global_ba_at_end false)";
  } else {
    // The last pose was tracked against the reference keyframe: it keeps its place relative to
    // it (as after a late local BA, finishLocalBa).
    const MapKeyframe* reference = map_.keyframe(reference_id_);
    const std::optional<Eigen::Isometry3d> T_world_reference_before =
        reference != nullptr ? std::optional<Eigen::Isometry3d>(reference->T_world_camera) : std::nullopt;
    end.global_ba = runGlobalBa();
    reference = map_.keyframe(reference_id_);
    if (end.global_ba.ran && T_world_reference_before && reference != nullptr) {
      T_world_last_ = reference->T_world_camera * T_world_reference_before->inverse() * T_world_last_;
      motion_.correctLast(T_world_last_);
      setReference(reference_id_);  // points moved or were removed: fresh views for any next frame
    }
    collectCorrections(/*new_keyframe_id=*/-1, &scratch);
  }
  end.corrected_keyframes = std::move(scratch.corrected_keyframes);
  return end;
}

FrameRefinementResult RgbdOdometry::refineRecordedPoses(std::vector<RecordedPose>* records) const {
  if (!has_pinhole_) return {};
  return frame_refiner_.refine(map_, pinhole_, records);
}

std::size_t RgbdOdometry::adoptKeyframePoses(const KeyframePoseCorrections& T_world_keyframe) {
  if (options_.localization_only) return 0;  // the loaded map is not changed
  std::map<std::int64_t, Eigen::Isometry3d> poses;
  for (const auto& [id, T] : T_world_keyframe) {
    if (map_.keyframe(id) != nullptr && T.matrix().allFinite()) poses.emplace(id, T);
  }
  if (poses.empty()) return 0;
  const MapKeyframe* reference = map_.keyframe(reference_id_);
  const std::optional<Eigen::Isometry3d> T_world_reference_before =
      reference != nullptr ? std::optional<Eigen::Isometry3d>(reference->T_world_camera) : std::nullopt;
  map_.applyKeyframePoses(poses);
  for (const auto& [id, T] : poses) {
    const auto it = reported_poses_.find(id);
    if (it != reported_poses_.end()) it->second = T;
  }
  reference = map_.keyframe(reference_id_);
  if (T_world_reference_before && reference != nullptr) {
    T_world_last_ = reference->T_world_camera * T_world_reference_before->inverse() * T_world_last_;
    motion_.correctLast(T_world_last_);
    setReference(reference_id_);
  }
  return poses.size();
}

}  // namespace tracking
}  // namespace dypho
