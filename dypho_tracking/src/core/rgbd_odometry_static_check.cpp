/// RgbdOdometry's dense check of a tracked pose against the reference keyframe's static pixels
/// (StaticSceneCheck), and the re-estimate when moving matches carried the feature pose.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/rgbd_odometry.h"

namespace dypho {
namespace tracking {
namespace {

/// The static check's dense pose counts as evidence only when it explains at least this share of
/// the reference keyframe's static samples.
constexpr double kMinDenseAgreement = 0.75;

/// Records a feature seen moving (TrackingResult::moving_points_camera_m) at its measured depth.
void addMovingPoint(const Pinhole& pinhole, const Eigen::Vector2d& uv_undistorted_px, double depth_m,
                    TrackingResult* result) {
  const Eigen::Vector3d p = pinhole.backProject(uv_undistorted_px, depth_m);
  result->moving_points_camera_m.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                                              static_cast<float>(p.z()));
}

/// The matches that the static scene's pose T_dense explains (reprojected within the refining
/// search radius): their pose observations and, per observation, the index of its match.
struct ExplainedMatches {
  std::vector<PoseObservation> observations;
  std::vector<std::size_t> match_of;
};

/// The matches of `aligned` (into `ref`) that T_dense explains (ExplainedMatches).
ExplainedMatches explainedMatches(const AlignmentResult& aligned, const KeyframePoints& ref,
                                  const FrameFeatures& features, const Pinhole& pinhole,
                                  const Eigen::Isometry3d& T_dense, const TrackingOptions& options) {
  ExplainedMatches explained;
  for (std::size_t m = 0; m < aligned.matches.size(); ++m) {
    const PoseObservation o = observationOf(aligned.matches[m], ref, features);
    const Eigen::Vector3d p_c = T_dense * o.p_world_m;
    if (p_c.z() < 1e-3) continue;
    const double radius_px = options.refine_search_radius_px * std::pow(options.scale_factor, std::max(0, o.level));
    if ((pinhole.project(p_c) - o.uv_px).norm() > radius_px) continue;
    explained.observations.push_back(o);
    explained.match_of.push_back(m);
  }
  return explained;
}

/// Records the matches of `aligned` not in `match_of` that have a depth as moving points.
void addUnexplainedMatches(const AlignmentResult& aligned, const std::vector<std::size_t>& match_of,
                           const FrameFeatures& features, const Pinhole& pinhole, TrackingResult* result) {
  std::vector<bool> explained(aligned.matches.size(), false);
  for (const std::size_t m : match_of) explained[m] = true;
  for (std::size_t m = 0; m < aligned.matches.size(); ++m) {
    const auto f = static_cast<std::size_t>(aligned.matches[m].frame_index);
    if (!explained[m] && features.depth_m[f] > 0.f) {
      addMovingPoint(pinhole, features.uv_undistorted_px[f], features.depth_m[f], result);
    }
  }
}

/// The inliers of `aligned` become the matches in `match_of` (those `refined` rejected not, when
/// its pose is used).
void keepExplainedInliers(const std::vector<std::size_t>& match_of, bool use_refined,
                          const PoseOptimizerResult& refined, AlignmentResult* aligned) {
  std::fill(aligned->inliers.begin(), aligned->inliers.end(), false);
  for (std::size_t k = 0; k < match_of.size(); ++k) aligned->inliers[match_of[k]] = !use_refined || refined.inliers[k];
  aligned->num_inliers = static_cast<int>(std::count(aligned->inliers.begin(), aligned->inliers.end(), true));
}

}  // namespace

Eigen::Isometry3d RgbdOdometry::denseStart(const Eigen::Isometry3d& T_features, double features_agreement,
                                           const Eigen::Isometry3d& T_world_reference) const {
  // The refinement converges only near the pose it starts from. Moving matches can drag the
  // feature pose out of that basin a little more on each frame, so it also may start where the
  // camera was on the last frame or at the reference keyframe: whichever of the three explains
  // most of the static samples.
  Eigen::Isometry3d T_start = T_features;
  double best_start = features_agreement;
  const Eigen::Isometry3d T_world_other_starts[] = {T_world_last_, T_world_reference};
  for (const Eigen::Isometry3d& T_world_candidate : T_world_other_starts) {
    if (!options_.static_check_other_starts) break;
    const Eigen::Isometry3d T_candidate = T_world_candidate.inverse();
    const double agreement = static_check_.score(T_candidate * T_world_reference).ratio();
    if (agreement > best_start) {
      best_start = agreement;
      T_start = T_candidate;
    }
  }
  return T_start;
}

void RgbdOdometry::checkAgainstStaticScene(const RgbdFrame& frame, const cv::Mat& mask, const FrameFeatures& features,
                                           const Pinhole& pinhole, AlignmentResult* aligned, TrackingResult* result) {
  const MapKeyframe* reference = map_.keyframe(reference_id_);
  if (reference == nullptr || !aligned->T_camera_world.matrix().allFinite()) return;
  const Eigen::Isometry3d T_world_reference = reference->T_world_camera;
  static_check_.setCurrent(frame, mask);
  const Eigen::Isometry3d T_features = aligned->T_camera_world;
  const StaticAgreement by_features = static_check_.score(T_features * T_world_reference);
  result->static_agreement = by_features.ratio();
  const Eigen::Isometry3d T_start = denseStart(T_features, by_features.ratio(), T_world_reference);
  const Eigen::Isometry3d T_dense = static_check_.refine(T_start * T_world_reference) * T_world_reference.inverse();
  const StaticAgreement by_dense = static_check_.score(T_dense * T_world_reference);
  // Evidence only when the refined pose explains most of the static samples (sharp images, a
  // static background that is really static) and clearly more than the feature pose does.
  if (!T_dense.matrix().allFinite() || by_dense.ratio() < kMinDenseAgreement) return;
  // Doubt until corrected: the keyframe policy does not anchor a periodic keyframe on this pose.
  result->static_check_doubt = std::max(0.0, by_dense.ratio() - by_features.ratio());
  if (by_dense.ratio() < by_features.ratio() + options_.static_check_min_gain) return;

  // Moving matches carried the feature pose. Re-estimate from the matches that the static scene's
  // pose explains (within the refining search radius), starting from that pose.
  const KeyframePoints& ref = aligned->matches_refer_to_fallback ? own_view_ : local_view_;
  const ExplainedMatches explained = explainedMatches(*aligned, ref, features, pinhole, T_dense, options_);
  if (static_cast<int>(explained.observations.size()) < options_.min_inliers) return;  // the features contradict it
  // Usually the re-estimate; the dense pose itself when the matches cannot tell the two apart
  // (the local map's points moved with the people while the reference keyframe's pixels did not).
  const PoseOptimizerResult refined = pose_optimizer_.optimize(explained.observations, pinhole, T_dense);
  const bool use_refined = refined.success && refined.num_inliers >= options_.min_inliers &&
                           static_check_.score(refined.T_camera_world * T_world_reference).ratio() >=
                               by_dense.ratio() - 0.5 * options_.static_check_min_gain;
  aligned->T_camera_world = use_refined ? refined.T_camera_world : T_dense;
  result->static_check_doubt = 0.0;
  // The matches the static scene's pose does not explain moved: the mask is told where they are.
  addUnexplainedMatches(*aligned, explained.match_of, features, pinhole, result);
  keepExplainedInliers(explained.match_of, use_refined, refined, aligned);
  const StaticAgreement by_final = static_check_.score(aligned->T_camera_world * T_world_reference);
  result->static_agreement = by_final.ratio();
  result->static_check_corrected = true;
  result->static_check_disputed = !use_refined;
  result->message = "static check: the feature pose explained " + std::to_string(by_features.ratio()) +
                    " of the keyframe's static samples, the corrected pose " + std::to_string(by_final.ratio()) +
                    " (moving matches had carried it)";
}

}  // namespace tracking
}  // namespace dypho
