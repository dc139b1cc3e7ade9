#include "dypho/tracking/keyframe_selector.h"

#include <cmath>
#include <sstream>

namespace dypho {
namespace tracking {

KeyframeSelector::KeyframeSelector(const TrackingOptions& options) : options_(options) { options_.validate(); }

double KeyframeSelector::minTrackedRatio(const KeyframeQuery& q) const {
  const bool sharp = q.frame_rotation_deg < options_.keyframe_sharp_max_frame_rotation_deg;
  return sharp && !q.camera_still && !q.catching_up ? options_.keyframe_sharp_tracked_ratio
                                                    : options_.keyframe_min_tracked_ratio;
}

KeyframeDecision KeyframeSelector::decide(const KeyframeQuery& q) const {
  KeyframeDecision decision;
  const double tracked_ratio = q.num_reference_inliers > 0
                                   ? static_cast<double>(q.num_inliers) / static_cast<double>(q.num_reference_inliers)
                                   : 0.0;
  std::ostringstream reason;
  if (tracked_ratio < options_.keyframe_hard_tracked_ratio) {
    reason << "tracked ratio " << tracked_ratio << " < " << options_.keyframe_hard_tracked_ratio << " (hard)";
  } else if (q.num_inliers < 3 * options_.min_inliers) {
    reason << q.num_inliers << " inliers < 3 * min_inliers (hard)";
  } else if (q.frame_rotation_deg > options_.keyframe_max_frame_rotation_deg) {
    return decision;  // soft triggers wait for a calmer frame
  } else if (q.pose_disputed && options_.keyframe_wait_while_disputed &&
             q.frames_since_keyframe < 2 * options_.keyframe_max_frames) {
    return decision;  // soft triggers wait for a pose its matches and pixels agree on
  } else {
    const Eigen::Isometry3d T_keyframe_camera = q.T_world_keyframe.inverse() * q.T_world_camera;
    const double translation_m = T_keyframe_camera.translation().norm();
    const double rotation_deg = Eigen::AngleAxisd(T_keyframe_camera.rotation()).angle() * 180.0 / M_PI;
    if (translation_m > options_.keyframe_translation_m) {
      reason << "translation " << translation_m << " m > " << options_.keyframe_translation_m << " m";
    } else if (rotation_deg > options_.keyframe_rotation_deg) {
      reason << "rotation " << rotation_deg << " deg > " << options_.keyframe_rotation_deg << " deg";
    } else if (const double min_ratio = minTrackedRatio(q); tracked_ratio < min_ratio) {
      reason << "tracked ratio " << tracked_ratio << " < " << min_ratio;
    } else if (q.frames_since_keyframe >= options_.keyframe_max_frames &&
               (options_.keyframe_static_doubt <= 0.0 || q.static_doubt <= options_.keyframe_static_doubt ||
                q.frames_since_keyframe >= 2 * options_.keyframe_max_frames)) {
      reason << q.frames_since_keyframe << " frames since the keyframe >= " << options_.keyframe_max_frames;
    } else {
      return decision;
    }
  }
  decision.is_keyframe = true;
  decision.reason = reason.str();
  return decision;
}

}  // namespace tracking
}  // namespace dypho
