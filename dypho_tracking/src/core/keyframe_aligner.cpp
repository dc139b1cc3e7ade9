#include "dypho/tracking/keyframe_aligner.h"

#include <chrono>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "dypho/tracking/rolling_shutter.h"

namespace dypho {
namespace tracking {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

/// Initial pose from brute-force matches by EPnP RANSAC; false when RANSAC fails.
bool solvePnp(const KeyframePoints& reference, const FrameFeatures& frame, const Pinhole& pinhole,
              const std::vector<FeatureMatch>& matches, const TrackingOptions& options,
              Eigen::Isometry3d* T_camera_world, int* num_inliers) {
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  object.reserve(matches.size());
  image.reserve(matches.size());
  for (const FeatureMatch& m : matches) {
    const Eigen::Vector3d& p = reference.p_world_m[static_cast<size_t>(m.reference_index)];
    const Eigen::Vector2d& uv = frame.uv_undistorted_px[static_cast<size_t>(m.frame_index)];
    object.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    image.emplace_back(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
  }
  const cv::Matx33d K(pinhole.fx, 0, pinhole.cx, 0, pinhole.fy, pinhole.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  bool ok = false;
  try {
    ok = cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false, options.ransac_iterations,
                            static_cast<float>(options.ransac_reprojection_px), 0.99, inliers, cv::SOLVEPNP_EPNP);
  } catch (const cv::Exception&) {
    ok = false;  // degenerate configurations make OpenCV throw; treat as failure
  }
  if (!ok || rvec.empty() || tvec.empty()) return false;
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  cv::cv2eigen(R_cv, R);
  cv::cv2eigen(tvec, t);
  if (!R.allFinite() || !t.allFinite()) return false;
  T_camera_world->setIdentity();
  T_camera_world->linear() = R;
  T_camera_world->translation() = t;
  *num_inliers = static_cast<int>(inliers.size());
  return true;
}

/// Per match: its reference point carries the pose (KeyframePoints::verified); empty when the
/// reference has no probation.
std::vector<bool> verifiedMatches(const KeyframePoints& reference, const std::vector<FeatureMatch>& matches) {
  std::vector<bool> verified;
  if (reference.verified.empty()) return verified;
  verified.reserve(matches.size());
  for (const FeatureMatch& m : matches) {
    verified.push_back(reference.verified[static_cast<std::size_t>(m.reference_index)] != 0);
  }
  return verified;
}

}  // namespace

PoseObservation observationOf(const FeatureMatch& match, const KeyframePoints& reference, const FrameFeatures& frame,
                              double readout_s) {
  const auto f = static_cast<std::size_t>(match.frame_index);
  PoseObservation o;
  o.p_world_m = reference.p_world_m[static_cast<std::size_t>(match.reference_index)];
  o.uv_px = frame.uv_undistorted_px[f];
  o.level = frame.keypoints[f].octave;
  o.depth_m = frame.depth_m[f];
  if (readout_s > 0.0 && frame.image_rows > 0) {
    o.row_time_s = rowTimeOffsetS(frame.keypoints[f].pt.y, frame.image_rows, readout_s);
  }
  return o;
}

KeyframeAligner::KeyframeAligner(const TrackingOptions& options)
    : options_(options), matcher_(options), optimizer_(options) {}

bool KeyframeAligner::refine(const KeyframePoints& reference, const FrameFeatures& frame, const Pinhole& pinhole,
                             const std::vector<FeatureMatch>& matches, const Eigen::Isometry3d& T_init,
                             bool use_verified_first, const CameraRates& rates_prior, AlignmentResult* result) const {
  std::vector<PoseObservation> observations;
  observations.reserve(matches.size());
  const double readout_s = options_.rolling_shutter_readout_ms * 1e-3;
  for (const FeatureMatch& m : matches) observations.push_back(observationOf(m, reference, frame, readout_s));
  // Probation: the verified points estimate the pose first; an unverified match that disagrees
  // with it takes no part (a verdict against its point), the others join the final estimate.
  const std::vector<bool> is_verified = verifiedMatches(reference, matches);
  const bool probation = !is_verified.empty();
  std::vector<std::int8_t> verdict(probation ? matches.size() : 0, 0);
  std::vector<std::size_t> taking_part;  // indices into matches / observations
  bool verified_first = false;
  Eigen::Isometry3d T_start = T_init;
  if (probation) {
    std::vector<PoseObservation> verified;
    for (std::size_t m = 0; m < matches.size(); ++m) {
      if (is_verified[m]) verified.push_back(observations[m]);
    }
    if (use_verified_first && static_cast<int>(verified.size()) >= options_.point_probation_min_verified) {
      const PoseOptimizerResult first = optimizer_.optimize(verified, pinhole, T_init, rates_prior);
      if (first.success && first.num_inliers >= options_.min_inliers) {
        verified_first = true;
        T_start = first.T_camera_world;
        for (std::size_t m = 0; m < matches.size(); ++m) {
          if (is_verified[m] || optimizer_.agrees(observations[m], pinhole, first)) {
            taking_part.push_back(m);
          } else {
            verdict[m] = -1;
          }
        }
      }
    }
  }
  std::vector<PoseObservation> used;
  if (verified_first) {
    used.reserve(taking_part.size());
    for (std::size_t m : taking_part) used.push_back(observations[m]);
  }
  PoseOptimizerResult opt = optimizer_.optimize(verified_first ? used : observations, pinhole, T_start, rates_prior);
  if (verified_first && opt.success) {
    // Back to one entry per match: the matches that took no part are outliers.
    std::vector<bool> inliers(matches.size(), false);
    for (std::size_t k = 0; k < taking_part.size(); ++k) inliers[taking_part[k]] = opt.inliers[k];
    opt.inliers = std::move(inliers);
  }
  if (probation && opt.success) {
    for (std::size_t m = 0; m < matches.size(); ++m) {
      if (!is_verified[m] && opt.inliers[m]) verdict[m] = 1;
    }
  }
  if (!opt.success || opt.num_inliers < options_.min_inliers) {
    result->message = "pose refinement kept " + std::to_string(opt.num_inliers) + " of " +
                      std::to_string(matches.size()) + " matches (need " + std::to_string(options_.min_inliers) + ")" +
                      (opt.message.empty() ? "" : ": " + opt.message);
    return false;
  }
  result->T_camera_world = opt.T_camera_world;
  result->rates = opt.rates;
  result->blur_exposure_s = opt.blur_exposure_s;
  result->blur_rates = opt.blur_rates;
  result->matches = matches;
  result->inliers = opt.inliers;
  result->num_inliers = opt.num_inliers;
  result->probation = std::move(verdict);
  result->verified_first = verified_first;
  result->success = true;
  result->message.clear();
  return true;
}

bool KeyframeAligner::guidedPass(const KeyframePoints& reference, const FrameFeatures& frame, const Pinhole& pinhole,
                                 const Eigen::Isometry3d& T_camera_world_predicted, double radius_px,
                                 const AlignmentSettings& settings, std::size_t* num_guided, AlignmentResult* result,
                                 TrackingTimesMs* times) const {
  auto t0 = Clock::now();
  const std::vector<FeatureMatch> guided = matcher_.matchByProjection(
      reference, frame, T_camera_world_predicted, pinhole, radius_px, settings.ratio_same_level_only);
  times->matching += msSince(t0);
  *num_guided = guided.size();
  if (static_cast<int>(guided.size()) < options_.min_inliers) return false;
  t0 = Clock::now();
  const bool ok = refine(reference, frame, pinhole, guided, T_camera_world_predicted, settings.verified_first,
                         settings.rates_prior, result);
  times->refine += msSince(t0);
  return ok;
}

AlignmentResult KeyframeAligner::align(const KeyframePoints& reference, const FrameFeatures& frame,
                                       const Pinhole& pinhole, const Eigen::Isometry3d& T_camera_world_predicted,
                                       TrackingTimesMs* times, const KeyframePoints* brute_force_reference,
                                       const AlignmentSettings& settings) const {
  const KeyframePoints& global_ref = brute_force_reference != nullptr ? *brute_force_reference : reference;
  TrackingTimesMs local;
  TrackingTimesMs& t = times != nullptr ? *times : local;
  AlignmentResult result;
  result.T_camera_world = T_camera_world_predicted;

  // 1. Guided by the prediction; when that fails (a jerk of the hand, frames dropped before this
  // one), guided again over a wider radius before the global search.
  std::size_t num_guided = 0;
  bool ok = guidedPass(reference, frame, pinhole, T_camera_world_predicted, options_.search_radius_px, settings,
                       &num_guided, &result, &t);
  if (!ok && options_.wide_search_radius_px > options_.search_radius_px) {
    ok = guidedPass(reference, frame, pinhole, T_camera_world_predicted, options_.wide_search_radius_px, settings,
                    &num_guided, &result, &t);
  }
  auto t0 = Clock::now();

  // 2. Global search + PnP RANSAC when the prediction did not work out.
  if (!ok) {
    t0 = Clock::now();
    const std::vector<FeatureMatch> global = matcher_.matchBruteForce(global_ref, frame);
    t.matching += msSince(t0);
    if (static_cast<int>(global.size()) < options_.min_inliers) {
      result.message = "only " + std::to_string(num_guided) + " guided and " + std::to_string(global.size()) +
                       " brute-force matches to keyframe (need " + std::to_string(options_.min_inliers) + ")";
      return result;
    }
    t0 = Clock::now();
    Eigen::Isometry3d T_pnp = Eigen::Isometry3d::Identity();
    int pnp_inliers = 0;
    const bool pnp_ok = solvePnp(global_ref, frame, pinhole, global, options_, &T_pnp, &pnp_inliers);
    t.pnp += msSince(t0);
    if (!pnp_ok || pnp_inliers < options_.min_inliers) {
      result.message = "PnP RANSAC found " + std::to_string(pnp_inliers) + " inliers among " +
                       std::to_string(global.size()) + " matches (need " + std::to_string(options_.min_inliers) + ")";
      return result;
    }
    result.used_pnp = true;
    result.matches_refer_to_fallback = brute_force_reference != nullptr;
    t0 = Clock::now();
    ok = refine(global_ref, frame, pinhole, global, T_pnp, settings.verified_first, settings.rates_prior, &result);
    t.refine += msSince(t0);
    if (!ok) return result;
  }

  // 3. Tight projection pass around the estimate for more (and better) matches.
  if (!settings.tight_pass) return result;
  t0 = Clock::now();
  const std::vector<FeatureMatch> tight =
      matcher_.matchByProjection(reference, frame, result.T_camera_world, pinhole, options_.refine_search_radius_px,
                                 settings.ratio_same_level_only);
  t.matching += msSince(t0);
  if (static_cast<int>(tight.size()) >= options_.min_inliers) {
    AlignmentResult second = result;
    t0 = Clock::now();
    if (refine(reference, frame, pinhole, tight, result.T_camera_world, settings.verified_first, settings.rates_prior,
               &second) &&
        second.num_inliers >= result.num_inliers / 2) {
      second.used_pnp = result.used_pnp;
      second.matches_refer_to_fallback = false;
      result = std::move(second);
    }
    t.refine += msSince(t0);
  }
  return result;
}

}  // namespace tracking
}  // namespace dypho
