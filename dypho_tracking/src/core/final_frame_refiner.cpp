#include "dypho/tracking/final_frame_refiner.h"

#include <algorithm>
#include <chrono>
#include <optional>

namespace dypho {
namespace tracking {

FinalFrameRefiner::FinalFrameRefiner(const TrackingOptions& options) : options_(options), optimizer_(options) {}

void FinalFrameRefiner::record(Timestamp stamp_ns, const AlignmentResult& aligned, const KeyframePoints& reference,
                               const FrameFeatures& features, double masked_fraction) {
  if (!options_.final_frame_refinement || options_.final_frame_refinement_max_frames <= 0) return;
  if (masked_fraction > options_.final_frame_refinement_max_masked_fraction) return;  // movers in view
  const double readout_s = options_.rolling_shutter_readout_ms * 1e-3;
  Evidence evidence;
  evidence.rates = aligned.rates;
  evidence.observations.reserve(static_cast<std::size_t>(aligned.num_inliers));
  for (std::size_t m = 0; m < aligned.matches.size() && m < aligned.inliers.size(); ++m) {
    if (!aligned.inliers[m]) continue;
    const FeatureMatch& match = aligned.matches[m];
    const PoseObservation o = observationOf(match, reference, features, readout_s);
    Observation kept;
    kept.point_id = reference.map_point_ids[static_cast<std::size_t>(match.reference_index)];
    kept.u_px = static_cast<float>(o.uv_px.x());
    kept.v_px = static_cast<float>(o.uv_px.y());
    kept.depth_m = static_cast<float>(o.depth_m);
    kept.row_time_s = static_cast<float>(o.row_time_s);
    kept.level = static_cast<std::uint8_t>(std::clamp(o.level, 0, 255));
    if (kept.point_id >= 0) evidence.observations.push_back(kept);
  }
  frames_[stamp_ns] = std::move(evidence);
  while (frames_.size() > static_cast<std::size_t>(options_.final_frame_refinement_max_frames)) {
    frames_.erase(frames_.begin());  // the oldest: its pose stays as tracked
  }
}

FrameRefinementResult FinalFrameRefiner::refine(const TrackerMap& map, const Pinhole& pinhole,
                                                std::vector<RecordedPose>* records) const {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const auto deadline = t0 + std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(options_.final_frame_refinement_max_seconds));
  FrameRefinementResult result;
  // Newest first: when the time budget ends the run's oldest frames keep their tracked poses.
  for (auto it = records->rbegin(); it != records->rend(); ++it) {
    RecordedPose& r = *it;
    if (r.reference_keyframe_id < 0) continue;  // not tracked: no pose
    if (Clock::now() > deadline) {
      ++result.frames_kept;
      ++result.frames_out_of_time;
      continue;
    }
    const auto found = frames_.find(r.stamp_ns);
    // A culled reference keyframe still has a pose, through the keyframe it was attached to.
    const std::optional<Eigen::Isometry3d> T_world_reference = map.keyframePose(r.reference_keyframe_id);
    const MapKeyframe* live_reference = map.keyframe(r.reference_keyframe_id);
    const bool keyframe_frame = live_reference != nullptr && live_reference->stamp_ns == r.stamp_ns;
    if (found == frames_.end() || !T_world_reference || keyframe_frame) {
      ++result.frames_kept;
      continue;
    }
    std::vector<PoseObservation> observations;
    observations.reserve(found->second.observations.size());
    for (const Observation& kept : found->second.observations) {
      const MapPoint* point = map.point(kept.point_id);
      if (point == nullptr) continue;  // removed since: culled, or an outlier of a later BA
      PoseObservation o;
      o.p_world_m = point->p_world_m;
      o.uv_px = Eigen::Vector2d(kept.u_px, kept.v_px);
      o.level = kept.level;
      o.depth_m = kept.depth_m;
      o.row_time_s = kept.row_time_s;
      observations.push_back(o);
    }
    if (static_cast<int>(observations.size()) < options_.min_inliers) {
      ++result.frames_kept;
      continue;
    }
    const Eigen::Isometry3d T_world_camera = *T_world_reference * r.T_reference_camera;
    const PoseOptimizerResult refined =
        optimizer_.optimize(observations, pinhole, T_world_camera.inverse(), found->second.rates);
    if (!refined.success || refined.num_inliers < options_.min_inliers ||
        !refined.T_camera_world.matrix().allFinite()) {
      ++result.frames_kept;
      continue;
    }
    r.T_reference_camera = T_world_reference->inverse() * refined.T_camera_world.inverse();
    ++result.frames_refined;
  }
  result.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return result;
}

}  // namespace tracking
}  // namespace dypho
