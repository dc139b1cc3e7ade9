#include "dypho/tracking/rgbd_odometry.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "dypho/tracking/keyframe_point_fuser.h"
#include "dypho/tracking/pinhole.h"
#include "rgbd_odometry_frame.h"

namespace dypho {
namespace tracking {
namespace {

using Clock = std::chrono::steady_clock;

/// A still camera (RgbdOdometry::cameraStill): the last tracked frame-to-frame motion under these
/// [m], [deg]. The mask's still test (cameraStill in dynamic_masker.h) allows 5 mm per frame too;
/// 0.2 deg moves the image by under 2 px at a 525 px focal length, its median-flow bound.
constexpr double kStillMaxStepM = 0.005;
constexpr double kStillMaxStepDeg = 0.2;

StaticSceneCheckSettings staticCheckSettings(const TrackingOptions& o) {
  StaticSceneCheckSettings s;
  s.scale = o.static_check_scale;
  s.depth_tolerance_m = o.moving_point_depth_tolerance_m;
  return s;
}

DenseAlignerSettings denseSettings(const TrackingOptions& o) {
  DenseAlignerSettings s;
  s.scale = o.dense_scale;
  s.levels = o.dense_levels;
  s.iterations = o.dense_iterations;
  s.depth_sigma_per_m2 = o.dense_depth_sigma_per_m2;
  return s;
}

}  // namespace

RgbdOdometry::RgbdOdometry(const TrackingOptions& options)
    : options_(options),
      preparer_(options),
      aligner_(options),
      selector_(options),
      map_(options),
      local_ba_(options),
      relocalizer_(options),
      loop_detector_(options),
      loop_closer_(options),
      global_ba_(options),
      pose_optimizer_(options),
      static_check_(staticCheckSettings(options)),
      dense_(denseSettings(options)),
      frame_refiner_(options) {}

void RgbdOdometry::reset() {
  if (pending_ba_.valid()) pending_ba_.wait();  // its copy belongs to the world being forgotten
  pending_ba_ = std::future<LocalBaSolution>();
  pending_ba_keyframe_id_ = -1;
  pending_ba_frames_left_ = 0;
  map_.clear();
  static_check_.clear();
  dense_.clear();
  frame_refiner_.clear();
  reference_id_ = -1;
  views_stale_ = false;
  local_view_ = KeyframePoints();
  own_view_ = KeyframePoints();
  T_world_last_.setIdentity();
  T_world_odom_.setIdentity();
  last_loop_keyframe_id_ = -1;
  unanchored_from_keyframe_id_ = -1;
  unverified_keyframe_id_ = -1;
  motion_.reset();
  reported_poses_.clear();
  has_stamp_ = false;
  last_stamp_ns_ = 0;
  frames_since_keyframe_ = 0;
  reference_inliers_ = 0;
  lost_frames_ = 0;
  searching_map_ = false;
  uncompensated_start_.reset();
}

std::string RgbdOdometry::explainFewFeatures(const RgbdFrame& frame, const OrbFeatures& orb,
                                             const FrameFeatures& features) const {
  std::ostringstream os;
  cv::Mat valid;
  cv::inRange(frame.depth_m, options_.min_depth_m, options_.max_depth_m, valid);  // NaN -> 0
  if (cv::countNonZero(valid) == 0) {
    os << "no valid depth in [" << options_.min_depth_m << ", " << options_.max_depth_m
       << "] m anywhere in the frame (all 0/NaN/out of range): check the depth stream, its "
          "registration and its unit (metres)";
  } else if (orb.masked_fraction >= 0.999) {
    os << "the whole image is masked as dynamic; no static area to track";
  } else if (static_cast<int>(orb.keypoints.size()) < options_.min_init_features) {
    os << "textureless or dark image: only " << orb.keypoints.size() << " ORB keypoints (masked fraction "
       << orb.masked_fraction << ")";
  } else {
    os << "only " << features.size() << " of " << orb.keypoints.size() << " keypoints have a valid depth";
  }
  os << "; need " << options_.min_init_features << " keypoints with depth to start";
  return os.str();
}

void RgbdOdometry::setReference(std::int64_t keyframe_id) {
  reference_id_ = keyframe_id;
  views_stale_ = false;
  // Keyframes of an unanchored segment's view come from the segment only.
  local_view_ = map_.trackingPoints(keyframe_id, std::max<std::int64_t>(0, unanchored_from_keyframe_id_));
  own_view_ = map_.keyframePoints(keyframe_id);
}

void RgbdOdometry::addKeyframe(const RgbdFrame& frame, const cv::Mat& mask, const FrameFeatures& features,
                               Eigen::Isometry3d T_world_tracked, const std::vector<std::int64_t>& tracked_point_ids,
                               const Pinhole& pinhole, TrackingResult* result, const CameraRates& blur_rates,
                               double blur_exposure_s) {
  pinhole_ = pinhole;  // for the global BA at the end of the run (finishRun)
  camera_ = frame.camera;
  has_pinhole_ = true;
  // The previous keyframe's adjustment goes into the map first; this frame was tracked against
  // the map before it, so its pose moves with the reference keyframe and its matches to points
  // removed since are dropped.
  const Eigen::Isometry3d T_world_camera = finishLocalBa(pinhole, result) * T_world_tracked;
  std::vector<std::int64_t> map_point_ids = tracked_point_ids;
  for (std::int64_t& id : map_point_ids) {
    if (id >= 0 && map_.point(id) == nullptr) id = -1;
  }
  MapKeyframe kf;
  kf.id = next_keyframe_id_++;
  unverified_keyframe_id_ = -1;  // a later keyframe: the first one's verification window ends
  kf.stamp_ns = frame.stamp_ns;
  kf.T_world_camera = T_world_camera;
  kf.features = features;
  kf.map_point_ids = map_point_ids;
  kf.blur_rates = blur_rates;
  kf.blur_exposure_s = blur_exposure_s;
  const std::int64_t id = kf.id;
  map_.addKeyframe(std::move(kf));
  fuseKeyframePoints(&map_, id, pinhole, options_);

  const auto t0 = Clock::now();
  if (catching_up_) {
    // Behind the camera: no local BA for this keyframe (the next keyframe's window covers it).
    afterLocalBa(id, /*keep_id=*/-1, pinhole, result);
  } else if (LocalBaProblem problem = local_ba_.prepare(map_, id, pinhole);
             options_.local_ba_async_frames > 0 && problem.message.empty()) {
    const LocalBundleAdjuster* adjuster = &local_ba_;
    pending_ba_ =
        std::async(std::launch::async, [adjuster, problem = std::move(problem)] { return adjuster->solve(problem); });
    pending_ba_keyframe_id_ = id;
    pending_ba_frames_left_ = options_.local_ba_async_frames;
    result->times.local_ba += msSince(t0);
  } else {
    local_ba_.apply(local_ba_.solve(problem), &map_);
    result->times.local_ba += msSince(t0);
    afterLocalBa(id, /*keep_id=*/-1, pinhole, result);
  }

  collectCorrections(id, result);
  MapKeyframe* stored = map_.mutableKeyframe(id);
  T_world_last_ = stored->T_world_camera;  // after BA / loop correction
  motion_.correctLast(T_world_last_);
  result->keyframe = makeKeyframe(id, frame, mask, stored->T_world_camera, stored->features, stored->map_point_ids);
  setReference(id);
  if (options_.static_check) static_check_.setReference(id, frame, mask);
  if (options_.dense_refinement) dense_.setReference(id, frame, mask);
  frames_since_keyframe_ = 0;
  reference_inliers_ = 0;
  result->T_world_camera = T_world_last_;
  result->is_keyframe = true;
  reported_poses_[id] = stored->T_world_camera;  // what mapping receives with the keyframe
}

void RgbdOdometry::cullKeyframes(std::int64_t newest_keyframe_id, std::int64_t keep_id) {
  const std::int64_t oldest_id = map_.keyframes().begin()->first;
  for (std::int64_t id : map_.covisibleKeyframes(newest_keyframe_id, options_.local_map_keyframes)) {
    if (id != oldest_id && id != keep_id && map_.isRedundant(id, options_.keyframe_cull_redundant_ratio)) {
      map_.removeKeyframe(id);
    }
  }
}

void RgbdOdometry::afterLocalBa(std::int64_t keyframe_id, std::int64_t keep_id, const Pinhole& pinhole,
                                TrackingResult* result) {
  auto t0 = Clock::now();
  if (options_.cull_min_found_ratio > 0) map_.cullPoints();
  if (options_.keyframe_cull_redundant_ratio > 0 && map_.keyframe(keyframe_id) != nullptr) {
    cullKeyframes(keyframe_id, keep_id);
  }
  result->times.local_ba += msSince(t0);
  t0 = Clock::now();
  if (map_.keyframe(keyframe_id) != nullptr) closeLoops(keyframe_id, pinhole, result);
  result->times.loop += msSince(t0);
  if (result->loop_closed) result->discontinuous = true;  // consumers must not difference across it
}

Eigen::Isometry3d RgbdOdometry::finishLocalBa(const Pinhole& pinhole, TrackingResult* result) {
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  if (!pending_ba_.valid()) return correction;
  const auto t0 = Clock::now();
  const LocalBaSolution solution = pending_ba_.get();  // waits when it has not finished
  const std::int64_t id = pending_ba_keyframe_id_;
  pending_ba_keyframe_id_ = -1;
  pending_ba_frames_left_ = 0;
  // The frames since the keyframe were tracked against the map before the adjustment: the last
  // pose keeps its place relative to the reference keyframe (which is never culled here).
  const MapKeyframe* reference = map_.keyframe(reference_id_);
  const std::optional<Eigen::Isometry3d> T_world_reference_before =
      reference != nullptr ? std::optional<Eigen::Isometry3d>(reference->T_world_camera) : std::nullopt;
  local_ba_.apply(solution, &map_);
  result->times.local_ba += msSince(t0);
  afterLocalBa(id, /*keep_id=*/reference_id_, pinhole, result);
  reference = map_.keyframe(reference_id_);
  if (T_world_reference_before && reference != nullptr) {
    correction = reference->T_world_camera * T_world_reference_before->inverse();
    T_world_last_ = correction * T_world_last_;
    motion_.correctLast(T_world_last_);
    result->T_correction = correction * result->T_correction;
  }
  views_stale_ = true;  // points moved or were removed: the views are rebuilt before matching
  collectCorrections(/*new_keyframe_id=*/-1, result);
  return correction;
}

void RgbdOdometry::collectCorrections(std::int64_t new_keyframe_id, TrackingResult* result) {
  // Removed keyframes too: mapping keeps their images, and their poses follow the keyframe they
  // were attached to.
  for (auto& [id, reported] : reported_poses_) {
    if (id == new_keyframe_id) continue;
    const std::optional<Eigen::Isometry3d> T_world_keyframe = map_.keyframePose(id);
    if (!T_world_keyframe) continue;
    const Eigen::Isometry3d delta = reported.inverse() * *T_world_keyframe;
    const double moved_m = delta.translation().norm();
    const double turned_rad = Eigen::AngleAxisd(delta.rotation()).angle();
    if (moved_m > options_.correction_min_translation_m || turned_rad > options_.correction_min_rotation_rad) {
      result->corrected_keyframes.emplace_back(id, *T_world_keyframe);
      reported = *T_world_keyframe;
    }
  }
}

void RgbdOdometry::closeLoops(std::int64_t keyframe_id, const Pinhole& pinhole, TrackingResult* result) {
  if (!options_.loop_closure) return;
  if (last_loop_keyframe_id_ >= 0 && keyframe_id - last_loop_keyframe_id_ < options_.loop_min_keyframe_gap) {
    return;
  }
  const LoopResult loop = loop_detector_.detect(map_, keyframe_id, pinhole);
  if (!loop.found) return;
  const LoopCorrection correction = loop_closer_.close(&map_, loop, unanchored_from_keyframe_id_);
  if (!correction.applied) {
    result->message = "loop with keyframe " + std::to_string(loop.loop_keyframe_id) +
                      " verified but not applied: " + correction.message;
    return;
  }
  last_loop_keyframe_id_ = keyframe_id;
  // A loop back to a keyframe from before a re-initialisation ties the new keyframes to the map.
  if (unanchored_from_keyframe_id_ >= 0 && loop.loop_keyframe_id < unanchored_from_keyframe_id_) {
    unanchored_from_keyframe_id_ = -1;
  }
  T_world_odom_ = correction.T_correction * T_world_odom_;
  result->loop_closed = true;
  result->message = "loop closed: keyframe " + std::to_string(keyframe_id) + " -> " +
                    std::to_string(loop.loop_keyframe_id) + " (" + std::to_string(loop.num_inliers) + " inliers, " +
                    std::to_string(correction.corrected_keyframes.size()) + " keyframes corrected, " +
                    std::to_string(correction.fused_points) + " points fused)";
  globalBaAfterLoop(keyframe_id, result);
}

bool RgbdOdometry::cameraStill() const {
  if (!motion_.hasVelocity()) return false;
  // Per frame interval: a step over a dropped frame spans two.
  const Eigen::Isometry3d& step = *motion_.lastStep();
  const double intervals = motion_.stepIntervals();
  return step.translation().norm() / intervals < kStillMaxStepM &&
         Eigen::AngleAxisd(step.rotation()).angle() * 180.0 / M_PI / intervals < kStillMaxStepDeg;
}

void RgbdOdometry::updatePointStatistics(const AlignmentResult& aligned, const Pinhole& pinhole,
                                         const FrameFeatures& features, const RgbdFrame& frame, const cv::Mat& mask,
                                         TrackingResult* result) {
  const int width = frame.bgr.cols, height = frame.bgr.rows;
  const double tolerance_m = options_.moving_point_depth_tolerance_m;
  auto depthAgrees = [tolerance_m](double z_point, double z_measured) {
    return std::abs(z_measured - z_point) < std::max(tolerance_m, 0.015 * z_point * z_point);
  };
  std::vector<std::int64_t> visible, found, on_dynamic;
  for (size_t i = 0; i < local_view_.size(); ++i) {
    const Eigen::Vector3d p_c = aligned.T_camera_world * local_view_.p_world_m[i];
    if (p_c.z() < 1e-3) continue;
    const Eigen::Vector2d uv = pinhole.project(p_c);
    if (uv.x() < 0 || uv.y() < 0 || uv.x() >= width || uv.y() >= height) continue;
    visible.push_back(local_view_.map_point_ids[i]);
    // On the dynamic mask at its own depth: the point lies on the moving surface (a point behind
    // it, occluded by a person, is farther than the measured depth and stays).
    if (mask.empty()) continue;
    const int u = static_cast<int>(uv.x()), v = static_cast<int>(uv.y());
    if (mask.at<uchar>(v, u) == 0) continue;
    const float z_measured = frame.depth_m.at<float>(v, u);
    if (z_measured > 0.f && std::isfinite(z_measured) && depthAgrees(p_c.z(), z_measured)) {
      on_dynamic.push_back(local_view_.map_point_ids[i]);
    }
  }
  const KeyframePoints& ref = aligned.matches_refer_to_fallback ? own_view_ : local_view_;
  for (size_t m = 0; m < aligned.matches.size(); ++m) {
    if (!aligned.inliers[m]) continue;
    const auto r = static_cast<size_t>(aligned.matches[m].reference_index);
    found.push_back(ref.map_point_ids[r]);
    // Matched where the image says, but not at the depth measured there: the point moved along
    // the line of sight (someone walking towards the camera).
    const double z_point = (aligned.T_camera_world * ref.p_world_m[r]).z();
    const double z_measured = features.depth_m[static_cast<size_t>(aligned.matches[m].frame_index)];
    if (!depthAgrees(z_point, z_measured)) on_dynamic.push_back(ref.map_point_ids[r]);
  }
  std::vector<std::int64_t> confirmed, refuted;
  for (size_t m = 0; m < aligned.probation.size(); ++m) {
    const std::int64_t id = ref.map_point_ids[static_cast<size_t>(aligned.matches[m].reference_index)];
    if (aligned.probation[m] > 0) confirmed.push_back(id);
    if (aligned.probation[m] < 0) refuted.push_back(id);
  }
  map_.updateVisibility(visible, found);
  std::vector<std::int64_t> moving = map_.cullMovingPoints(on_dynamic, options_.moving_point_min_hits, cameraStill(),
                                                           options_.moving_point_still_only);
  if (unverified_keyframe_id_ >= 0) {
    const std::vector<std::int64_t> unverified =
        map_.removePointsCreatedBy(unverified_keyframe_id_, on_dynamic, options_.first_keyframe_moving_hits);
    moving.insert(moving.end(), unverified.begin(), unverified.end());
  }
  const std::vector<std::int64_t> refuted_removed = map_.updateProbation(confirmed, refuted);
  moving.insert(moving.end(), refuted_removed.begin(), refuted_removed.end());
  result->num_moving_points_removed = static_cast<int>(moving.size());
  // The views must not offer removed points to the next frame; this frame's matches still index
  // the current views (keyframe creation below), so they are refreshed before the next frame.
  if (!moving.empty()) views_stale_ = true;
}

}  // namespace tracking
}  // namespace dypho
