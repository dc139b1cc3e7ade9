#pragma once
/// \file final_frame_refiner.h
/// Each tracked frame's pose optimised once more at the end of a run, against the final map.
///
/// A frame is tracked against the local map as it is at that moment: points triangulated from
/// one or two keyframes, before the local BA of the keyframes that follow and before the final
/// global BA have refined them. The saved trajectory keeps each frame relative to its reference
/// keyframe, so it follows the keyframe corrections, but not the points' own refinement. This
/// class keeps the inlier observations of every tracked frame (its keypoints, by map point) and,
/// after the final global BA, optimises the frame's pose again with the same estimator as
/// tracking (PoseOptimizer: Huber, chi2 rounds, depth, rolling shutter and blur with the frame's
/// own velocities) against the final positions of the points it matched. RgbdOdometry records no
/// evidence for a frame whose pose the static check or the dense refinement set: that pose came
/// from pixels, and its matches may be the moving ones that had carried the feature pose. Nor for
/// a frame whose mask found movers in view (final_frame_refinement_max_masked_fraction): among
/// its inliers there may be points on people that stood still then, and against those the
/// tracked pose, checked by the static check, is the safer one (Bonn crowd: every frame refined
/// lost on five of six inputs).

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

#include "dypho/common/types.h"
#include "dypho/tracking/keyframe_aligner.h"
#include "dypho/tracking/keyframe_points.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/pose_optimizer.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/trajectory_recorder.h"

namespace dypho {
namespace tracking {

/// What refine() did.
struct FrameRefinementResult {
  std::size_t frames_refined = 0;  ///< poses replaced
  /// Tracked frames left as they were: no evidence kept (older than the newest
  /// final_frame_refinement_max_frames, movers in view, or a pose set by pixels), a keyframe's own frame (the
  /// global BA refines it), too few of their points left in the map, or fewer than min_inliers
  /// inliers in the optimiser's result.
  std::size_t frames_kept = 0;
  /// Of frames_kept, those the time budget (final_frame_refinement_max_seconds) left as tracked.
  std::size_t frames_out_of_time = 0;
  double ms = 0.0;  ///< wall time of refine() [ms]
};

/// Keeps the tracked frames' inlier observations (TrackingOptions::final_frame_refinement, at most
/// final_frame_refinement_max_frames, the newest) and refines their recorded poses against a map.
class FinalFrameRefiner {
 public:
  explicit FinalFrameRefiner(const TrackingOptions& options);

  /// Keeps the inlier matches of `aligned` (into `reference`, keypoints of `features`) as the
  /// evidence of the frame at `stamp_ns`; its velocities (aligned.rates) are kept with them.
  /// Does nothing when the option is off, or when the frame's mask called more than
  /// final_frame_refinement_max_masked_fraction of it dynamic (`masked_fraction`, [0, 1]).
  void record(Timestamp stamp_ns, const AlignmentResult& aligned, const KeyframePoints& reference,
              const FrameFeatures& features, double masked_fraction = 0.0);

  /// Optimises the pose of every record with evidence against `map` (the points' current
  /// positions), from its current pose (reference keyframe * T_reference_camera, a culled
  /// reference keyframe's pose taken through the keyframe it was attached to,
  /// TrackerMap::keyframePose), and replaces its T_reference_camera when the optimiser keeps at
  /// least min_inliers inliers. Newest first, for at most final_frame_refinement_max_seconds.
  FrameRefinementResult refine(const TrackerMap& map, const Pinhole& pinhole, std::vector<RecordedPose>* records) const;

  void clear() { frames_.clear(); }
  std::size_t framesKept() const { return frames_.size(); }

 private:
  /// One inlier observation, compact (a long run keeps many).
  struct Observation {
    std::int64_t point_id = -1;
    float u_px = 0.0F, v_px = 0.0F;  ///< undistorted keypoint [px]
    float depth_m = 0.0F;            ///< measured depth, 0 = none [m]
    float row_time_s = 0.0F;         ///< its row's exposure time relative to the stamp [s]
    std::uint8_t level = 0;          ///< pyramid level
  };
  struct Evidence {
    std::vector<Observation> observations;
    CameraRates rates;
  };

  TrackingOptions options_;
  PoseOptimizer optimizer_;
  std::map<Timestamp, Evidence> frames_;
};

}  // namespace tracking
}  // namespace dypho
