#include "dypho/tracking/keyframe_selector.h"

#include <cmath>
#include <sstream>

namespace dypho {
namespace tracking {

KeyframeSelector::KeyframeSelector(const TrackingOptions& options) : options_(options) {
  options_.validate();
}

KeyframeDecision KeyframeSelector::decide(const Eigen::Isometry3d& T_world_keyframe,
                                          const Eigen::Isometry3d& T_world_camera,
                                          int num_inliers, int num_reference_inliers,
                                          int frames_since_keyframe) const {
  KeyframeDecision decision;
  const Eigen::Isometry3d T_keyframe_camera = T_world_keyframe.inverse() * T_world_camera;
  const double translation_m = T_keyframe_camera.translation().norm();
  const double rotation_deg =
      Eigen::AngleAxisd(T_keyframe_camera.rotation()).angle() * 180.0 / M_PI;
  const double tracked_ratio =
      num_reference_inliers > 0 ? static_cast<double>(num_inliers) / num_reference_inliers : 0.0;
  std::ostringstream reason;
  if (translation_m > options_.keyframe_translation_m) {
    reason << "translation " << translation_m << " m > " << options_.keyframe_translation_m << " m";
  } else if (rotation_deg > options_.keyframe_rotation_deg) {
    reason << "rotation " << rotation_deg << " deg > " << options_.keyframe_rotation_deg << " deg";
  } else if (tracked_ratio < options_.keyframe_min_tracked_ratio) {
    reason << "tracked ratio " << tracked_ratio << " < " << options_.keyframe_min_tracked_ratio;
  } else if (frames_since_keyframe >= options_.keyframe_max_frames) {
    reason << frames_since_keyframe << " frames since the keyframe >= "
           << options_.keyframe_max_frames;
  } else {
    return decision;
  }
  decision.is_keyframe = true;
  decision.reason = reason.str();
  return decision;
}

}  // namespace tracking
}  // namespace dypho
