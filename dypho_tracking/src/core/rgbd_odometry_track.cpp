/// RgbdOdometry::track as its steps: admit the frame, prepare its features, predict, match and
/// optimise, verify, then either keep the pose (local-map bookkeeping, keyframe decision and
/// insertion) or relocalise / count the frame lost.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/rgbd_odometry.h"
#include "dypho/tracking/rolling_shutter.h"
#include "rgbd_odometry_frame.h"

namespace dypho {
namespace tracking {
namespace {

using Clock = std::chrono::steady_clock;

/// A first keyframe nothing judged has its points verified (first_keyframe_moving_hits). Unsaid,
/// a mask that calls nothing dynamic counts as unjudged: the flow needs a previous frame, and a
/// mask that found people judged the frame.
bool unjudged(const cv::Mat& mask, MaskJudgement judgement) {
  if (judgement != MaskJudgement::kUnknown) return judgement == MaskJudgement::kUnjudged;
  return mask.empty() || cv::countNonZero(mask) == 0;
}

/// How far the camera turned between the reference keyframe and this frame, judged by the image
/// alone [deg]: the median displacement of the matches from where the reference keyframe saw
/// their points, as an angle. Independent of the tracked pose, which moving matches may carry;
/// -1 without matches.
double imageTurnDeg(const std::vector<FeatureMatch>& matches, const KeyframePoints& reference_points,
                    const FrameFeatures& features, const Pinhole& pinhole, const Eigen::Isometry3d& T_world_reference) {
  const Eigen::Isometry3d T_reference_world = T_world_reference.inverse();
  std::vector<double> displacement_px;
  displacement_px.reserve(matches.size());
  for (const FeatureMatch& m : matches) {
    const Eigen::Vector3d p_reference =
        T_reference_world * reference_points.p_world_m[static_cast<std::size_t>(m.reference_index)];
    if (p_reference.z() < 1e-3) continue;
    displacement_px.push_back(
        (pinhole.project(p_reference) - features.uv_undistorted_px[static_cast<std::size_t>(m.frame_index)]).norm());
  }
  if (displacement_px.empty()) return -1.0;
  auto median = displacement_px.begin() + static_cast<std::ptrdiff_t>(displacement_px.size() / 2);
  std::nth_element(displacement_px.begin(), median, displacement_px.end());
  return std::atan(*median / pinhole.fx) * 180.0 / M_PI;
}

/// The pose observations of the inlier matches of `aligned` (into `ref`), with their rows' times
/// under a rolling shutter read out over `readout_s` (0: global shutter).
std::vector<PoseObservation> inlierObservations(const AlignmentResult& aligned, const KeyframePoints& ref,
                                                const FrameFeatures& features, double readout_s) {
  std::vector<PoseObservation> observations;
  for (std::size_t m = 0; m < aligned.matches.size(); ++m) {
    if (aligned.inliers[m]) observations.push_back(observationOf(aligned.matches[m], ref, features, readout_s));
  }
  return observations;
}

}  // namespace

TrackingResult RgbdOdometry::track(const RgbdFrame& frame, const cv::Mat& mask, MaskJudgement judgement,
                                   const PreparedFeatures* prepared, int frames_waiting) {
  TrackingFrame work(frame, mask, judgement);
  beginFrame(frames_waiting, &work);
  if (!admitInput(&work) || !admitStamp(&work)) return finishFrame(&work);
  work.pinhole = Pinhole::fromIntrinsics(frame.camera);
  // The local BA in flight is applied at its frame, before this frame is matched against the map.
  if (pending_ba_.valid() && --pending_ba_frames_left_ <= 0) finishLocalBa(work.pinhole, &work.result);
  prepareFeatures(prepared, &work);
  if (reference_id_ < 0) {
    if (options_.localization_only) {
      work.result.message =
          "localization_only: no map to localise in; restore a saved session first (RgbdOdometry::restoreSession, "
          "dypho_run_dataset --resume DIR)";
    } else {
      startMap(&work);
    }
    return finishFrame(&work);
  }
  if (searching_map_) {
    searchMap(&work);
    return finishFrame(&work);
  }

  predictPose(&work);
  matchAndOptimise(&work);
  verifyPose(&work);
  refineDensely(&work);
  if (work.aligned.success) {
    const std::string stray = strayFromPrediction(work, work.T_world_camera, work.aligned.num_inliers);
    if (!stray.empty()) {  // lost: relocalisation may still find it
      work.aligned.success = false;
      work.aligned.message = "tracked " + stray;
    }
  }
  if (work.aligned.success && work.T_world_camera.matrix().allFinite()) {
    acceptPose(&work);
    compensateStartKeyframe(&work);
    // A pose the static check or the dense refinement set came from pixels, not from these
    // matches (moving ones may have carried them): it is kept as it is.
    if (!work.result.static_check_corrected && work.result.dense_correction_m < 0.0) {
      frame_refiner_.record(frame.stamp_ns, work.aligned,
                            work.aligned.matches_refer_to_fallback ? own_view_ : local_view_, work.features(),
                            work.result.masked_fraction);
    }
    if (options_.localization_only) {  // the map stays as loaded: only the reference follows
      followMap(work);
      return finishFrame(&work);
    }
    // Local map: the points' visibility and moving-point culling, then a keyframe when due.
    updatePointStatistics(work.aligned, work.pinhole, work.features(), frame, mask, &work.result);
    if (decideKeyframe(work).is_keyframe) insertKeyframe(&work);
    return finishFrame(&work);
  }

  // Lost: relocalise against the map's keyframes.
  if (!relocalise(&work)) markLost(&work);
  return finishFrame(&work);
}

void RgbdOdometry::beginFrame(int frames_waiting, TrackingFrame* work) {
  TrackingResult& result = work->result;
  catching_up_ = options_.catch_up_frames_waiting > 0 && frames_waiting >= options_.catch_up_frames_waiting;
  result.caught_up = catching_up_;
  result.stamp_ns = work->frame.stamp_ns;
  result.T_world_camera = T_world_last_;
  result.state = reference_id_ >= 0 ? TrackingState::kLost : TrackingState::kNotInitialized;
}

TrackingResult RgbdOdometry::finishFrame(TrackingFrame* work) const {
  TrackingResult& result = work->result;
  result.T_world_odom = T_world_odom_;
  if (const MapKeyframe* reference = reference_id_ >= 0 ? map_.keyframe(reference_id_) : nullptr) {
    result.reference_keyframe_id = reference_id_;
    result.T_reference_camera = reference->T_world_camera.inverse() * result.T_world_camera;
  }
  result.anchored = unanchored_from_keyframe_id_ < 0;
  result.num_map_points = static_cast<int>(map_.points().size());
  result.num_keyframes = static_cast<int>(map_.keyframes().size());
  result.times.total = msSince(work->t_start);
  return result;
}

bool RgbdOdometry::admitInput(TrackingFrame* work) {
  const std::string problem = checkTrackingInput(work->frame, work->mask);
  if (problem.empty()) return true;
  work->result.message = "bad input: " + problem;
  if (reference_id_ >= 0) {
    ++lost_frames_;
    motion_.observe({work->frame.stamp_ns, T_world_last_, /*trusted=*/false, false});
  }
  return false;
}

bool RgbdOdometry::admitStamp(TrackingFrame* work) {
  const Timestamp stamp_ns = work->frame.stamp_ns;
  if (has_stamp_ && stamp_ns <= last_stamp_ns_) {
    TrackingResult& result = work->result;
    result.discontinuous = true;
    std::ostringstream os;
    os << "stamp " << stamp_ns << " ns is not after the previous " << last_stamp_ns_
       << " ns (time jumped backwards or repeated, e.g. a bag restarted): tracker reset, the next "
          "frame starts a new world at identity";
    reset();
    result.message = os.str();
    result.state = TrackingState::kNotInitialized;
    result.T_world_camera.setIdentity();
    has_stamp_ = true;
    last_stamp_ns_ = stamp_ns;
    return false;
  }
  has_stamp_ = true;
  last_stamp_ns_ = stamp_ns;
  return true;
}

void RgbdOdometry::prepareFeatures(const PreparedFeatures* prepared, TrackingFrame* work) {
  // Features with depth.
  // (input checked above, so a valid preparation exists for this frame)
  if (prepared == nullptr || !prepared->valid || prepared->stamp_ns != work->frame.stamp_ns) {
    work->prepared_here = preparer_.prepare(work->frame, work->mask);
    prepared = &work->prepared_here;
  }
  work->prepared = prepared;
  TrackingResult& result = work->result;
  result.times.features = prepared->ms;
  result.num_features = static_cast<int>(prepared->features.size());
  result.masked_fraction = prepared->orb.masked_fraction;
  work->enough_to_start = result.num_features >= options_.min_init_features;
  work->enough_to_match = result.num_features >= options_.min_inliers;
}

void RgbdOdometry::startMap(TrackingFrame* work) {
  TrackingResult& result = work->result;
  if (!work->enough_to_start) {
    result.message = explainFewFeatures(work->frame, work->prepared->orb, work->features());
    return;
  }
  addKeyframe(work->frame, work->mask, work->features(), T_world_last_, {}, work->pinhole, &result);
  holdUncompensatedStart(*work);
  if (options_.first_keyframe_moving_hits > 0 && unjudged(work->mask, work->judgement))
    unverified_keyframe_id_ = reference_id_;
  result.state = TrackingState::kOk;
  result.discontinuous = true;  // a new world starts here
  motion_.observe({work->frame.stamp_ns, T_world_last_, /*trusted=*/true, /*discontinuous=*/true});
}

void RgbdOdometry::predictPose(TrackingFrame* work) {
  if (views_stale_) setReference(reference_id_);
  if (!work->enough_to_match) return;
  work->T_world_predicted = motion_.predict(work->frame.stamp_ns).value_or(T_world_last_);
}

void RgbdOdometry::matchAndOptimise(TrackingFrame* work) {
  if (!work->enough_to_match) {
    work->aligned.message = explainFewFeatures(work->frame, work->prepared->orb, work->features());
    return;
  }
  // With a rolling shutter the refinement estimates the camera's velocities too, about the motion
  // model's: the last step T_prev_last over its time, in the last camera's frame (zero without one).
  // With an exposure the same velocities set each keypoint's blur.
  AlignmentSettings settings;
  const bool moving_camera_model = options_.rolling_shutter_readout_ms > 0.0 || options_.motion_blur_exposure_ms > 0.0;
  if (moving_camera_model && motion_.hasVelocity() && motion_.stepNs() > 0) {
    settings.rates_prior = ratesOfStep(*motion_.lastStep(), timestampToSeconds(motion_.stepNs()));
  }
  const bool still = cameraStill();
  settings.verified_first = !still;
  settings.tight_pass = !catching_up_;
  // The ratio test across pyramid levels only on a sharp frame (the motion model's last turn) of
  // a moving camera: a still one sees its corners at their levels, and the people before it drag
  // the pose with any extra match.
  const std::optional<double> turn_deg = motion_.turnPerIntervalDeg();
  settings.ratio_same_level_only = !still && turn_deg && *turn_deg < options_.ratio_test_same_level_max_rotation_deg;
  work->aligned = aligner_.align(local_view_, work->features(), work->pinhole, work->T_world_predicted.inverse(),
                                 &work->result.times, &own_view_, settings);
}

double RgbdOdometry::frameTurnDeg(const TrackingFrame& work) const {
  // The photometric comparison needs sharp images: no motion blur or rolling-shutter skew. The
  // camera's turn per frame is the motion model's last step. Without one (the frame after a start
  // or a relocalisation) it is judged by the image: the tracked pose's own turn would let moving
  // matches that carry the pose also switch the check off.
  double turn_deg = -1.0;
  if (motion_.hasVelocity()) {
    turn_deg = *motion_.turnPerIntervalDeg();
  } else if (work.aligned.success && map_.keyframe(reference_id_) != nullptr) {
    const AlignmentResult& aligned = work.aligned;
    turn_deg = imageTurnDeg(aligned.matches, aligned.matches_refer_to_fallback ? own_view_ : local_view_,
                            work.features(), work.pinhole, map_.keyframe(reference_id_)->T_world_camera);
  }
  return turn_deg;
}

void RgbdOdometry::verifyPose(TrackingFrame* work) {
  const double turn_deg = frameTurnDeg(*work);
  work->turn_deg = turn_deg;
  const bool slow = turn_deg >= 0.0 && turn_deg < options_.static_check_max_frame_rotation_deg;
  if (work->aligned.success && options_.static_check && slow && static_check_.referenceId() == reference_id_) {
    const auto t_check = Clock::now();
    checkAgainstStaticScene(work->frame, work->mask, work->features(), work->pinhole, &work->aligned, &work->result);
    work->result.times.static_check = msSince(t_check);
  }
  work->T_world_camera = work->aligned.T_camera_world.inverse();
}

void RgbdOdometry::refineDensely(TrackingFrame* work) {
  const MapKeyframe* reference = map_.keyframe(reference_id_);
  AlignmentResult& aligned = work->aligned;
  if (!options_.dense_refinement || catching_up_ || !aligned.success || reference == nullptr ||
      dense_.referenceId() != reference_id_ || !aligned.T_camera_world.matrix().allFinite() ||
      !(work->turn_deg >= 0.0 && work->turn_deg < options_.dense_max_frame_rotation_deg)) {
    return;
  }
  const auto t_dense = Clock::now();
  const Eigen::Isometry3d T_world_reference = reference->T_world_camera;
  const Eigen::Isometry3d T_features = aligned.T_camera_world;
  DensePosePrior prior;
  prior.T_current_reference = T_features * T_world_reference;
  if (options_.dense_feature_prior_weight > 0.0) {
    const KeyframePoints& ref = aligned.matches_refer_to_fallback ? own_view_ : local_view_;
    prior.information = options_.dense_feature_prior_weight *
                        featurePoseInformation(pose_optimizer_, inlierObservations(aligned, ref, work->features(), 0.0),
                                               work->pinhole, T_features);
  }
  dense_.setCurrent(work->frame, work->mask);
  const DenseAlignment dense = dense_.align(prior.T_current_reference, prior);
  work->result.times.dense = msSince(t_dense);
  if (!dense.success) return;
  const Eigen::Isometry3d T_dense = dense.T_current_reference * T_world_reference.inverse();
  const Eigen::Isometry3d correction = T_dense * T_features.inverse();
  const double correction_deg = Eigen::AngleAxisd(correction.rotation()).angle() * 180.0 / M_PI;
  if (correction.translation().norm() > options_.dense_max_correction_m ||
      correction_deg > options_.dense_max_correction_deg) {
    return;  // left the feature pose's basin: a wrong minimum, not a refinement
  }
  aligned.T_camera_world = T_dense;
  work->T_world_camera = T_dense.inverse();
  work->result.dense_correction_m = correction.translation().norm();
}

std::string RgbdOdometry::strayFromPrediction(const TrackingFrame& work, const Eigen::Isometry3d& T_world_camera,
                                              int num_inliers) const {
  if (!options_.localization_only || searching_map_ || !work.enough_to_match ||
      num_inliers >= options_.localization_confident_inliers) {
    return "";
  }
  // The camera may have moved farther while lost: the limits grow with each frame lost since.
  const double frames = 1.0 + lost_frames_;
  const Eigen::Isometry3d jump = work.T_world_predicted.inverse() * T_world_camera;
  const double jump_m = jump.translation().norm();
  const double jump_deg = Eigen::AngleAxisd(jump.rotation()).angle() * 180.0 / M_PI;
  if (jump_m <= frames * options_.localization_max_jump_m && jump_deg <= frames * options_.localization_max_jump_deg) {
    return "";
  }
  std::ostringstream os;
  os << std::setprecision(3) << jump_m << " m, " << jump_deg << " deg from the prediction with " << num_inliers
     << " inliers: refused (localization_max_jump_m/deg, localization_confident_inliers)";
  return os.str();
}

void RgbdOdometry::acceptPose(TrackingFrame* work) {
  const AlignmentResult& aligned = work->aligned;
  const Eigen::Isometry3d& T_world_camera = work->T_world_camera;
  // Velocity only from consecutive good frames (a lost frame reset the model).
  motion_.observe({work->frame.stamp_ns, T_world_camera, /*trusted=*/true, /*discontinuous=*/false});
  T_world_last_ = T_world_camera;
  lost_frames_ = 0;
  ++frames_since_keyframe_;
  if (frames_since_keyframe_ == 1) reference_inliers_ = aligned.num_inliers;
  TrackingResult& result = work->result;
  result.state = TrackingState::kOk;
  result.T_world_camera = T_world_camera;
  result.num_matches = static_cast<int>(aligned.matches.size());
  result.num_inliers = aligned.num_inliers;
  const KeyframePoints& ref = aligned.matches_refer_to_fallback ? own_view_ : local_view_;
  result.pose_covariance = poseCovariance(
      pose_optimizer_, inlierObservations(aligned, ref, work->features(), options_.rolling_shutter_readout_ms * 1e-3),
      work->pinhole, aligned.T_camera_world, aligned.rates, aligned.blur_rates, aligned.blur_exposure_s);
}

KeyframeDecision RgbdOdometry::decideKeyframe(const TrackingFrame& work) const {
  KeyframeQuery query;
  query.T_world_keyframe = map_.keyframe(reference_id_)->T_world_camera;
  query.T_world_camera = work.T_world_camera;
  query.num_inliers = work.aligned.num_inliers;
  query.num_reference_inliers = reference_inliers_;
  query.frames_since_keyframe = frames_since_keyframe_;
  query.static_doubt = work.result.static_check_doubt;
  query.catching_up = catching_up_;
  query.camera_still = cameraStill();
  query.pose_disputed = work.result.static_check_disputed;
  // Inter-frame rotation; unknown (0) right after lost frames.
  query.frame_rotation_deg = motion_.turnPerIntervalDeg().value_or(0.0);
  return selector_.decide(query);
}

void RgbdOdometry::insertKeyframe(TrackingFrame* work) {
  const AlignmentResult& aligned = work->aligned;
  const KeyframePoints& ref = aligned.matches_refer_to_fallback ? own_view_ : local_view_;
  std::vector<std::int64_t> ids(work->features().size(), -1);
  for (size_t m = 0; m < aligned.matches.size(); ++m) {
    if (!aligned.inliers[m]) continue;
    const std::int64_t id = ref.map_point_ids[static_cast<size_t>(aligned.matches[m].reference_index)];
    if (map_.point(id) != nullptr) ids[static_cast<size_t>(aligned.matches[m].frame_index)] = id;
  }
  // With a rolling shutter the keyframe's points are made from its keypoints as the camera at the
  // stamp saw them, turned by the angular velocity the pose refinement estimated.
  const double readout_s = options_.rolling_shutter_readout_ms * 1e-3;
  const bool moved =
      readout_s > 0.0 && !(aligned.rates.omega_rad_s.isZero(0.0) && aligned.rates.velocity_m_s.isZero(0.0));
  FrameFeatures at_stamp;
  if (moved) {
    at_stamp = compensateRollingShutter(work->features(), work->frame.depth_m, work->frame.camera,
                                        aligned.rates.omega_rad_s, readout_s, aligned.rates.velocity_m_s);
  }
  addKeyframe(work->frame, work->mask, moved ? at_stamp : work->features(), work->T_world_camera, ids, work->pinhole,
              &work->result, aligned.rates, aligned.blur_exposure_s);
}

void RgbdOdometry::followMap(const TrackingFrame& work) {
  // The keyframe that observes most of the frame's inlier points becomes the reference (its
  // local map is what the next frame is matched against), as ORB-SLAM's localisation mode.
  const AlignmentResult& aligned = work.aligned;
  const KeyframePoints& ref = aligned.matches_refer_to_fallback ? own_view_ : local_view_;
  std::map<std::int64_t, int> seen;
  for (std::size_t m = 0; m < aligned.matches.size(); ++m) {
    if (!aligned.inliers[m]) continue;
    const MapPoint* point = map_.point(ref.map_point_ids[static_cast<std::size_t>(aligned.matches[m].reference_index)]);
    if (point == nullptr) continue;
    for (const auto& [keyframe_id, feature] : point->observations) ++seen[keyframe_id];
  }
  std::int64_t best_id = reference_id_;
  int best = seen.count(reference_id_) > 0 ? seen[reference_id_] : 0;
  for (const auto& [keyframe_id, count] : seen) {
    if (count > best && map_.keyframe(keyframe_id) != nullptr) {
      best = count;
      best_id = keyframe_id;
    }
  }
  if (best_id != reference_id_) setReference(best_id);
}

void RgbdOdometry::searchMap(TrackingFrame* work) {
  work->aligned.message = "searching the loaded map";
  if (!relocalise(work)) markLost(work);
}

bool RgbdOdometry::relocalise(TrackingFrame* work) {
  TrackingResult& result = work->result;
  if (result.num_features < options_.relocalization_min_inliers) return false;
  const auto t_reloc = Clock::now();
  const RelocalizationResult reloc =
      relocalizer_.relocalize(map_, work->features(), work->pinhole, &result.times, searching_map_);
  result.times.relocalization = msSince(t_reloc);
  if (!reloc.success) {
    work->aligned.message += "; " + reloc.message;
    return false;
  }
  if (const std::string stray = strayFromPrediction(*work, reloc.T_world_camera, reloc.num_inliers); !stray.empty()) {
    work->aligned.message += "; relocalised against keyframe " + std::to_string(reloc.keyframe_id) + " " + stray;
    return false;
  }
  T_world_last_ = reloc.T_world_camera;
  motion_.observe({work->frame.stamp_ns, T_world_last_, /*trusted=*/true, /*discontinuous=*/true});
  lost_frames_ = 0;
  searching_map_ = false;
  // Found again on the map from before a re-initialisation: anchored again (before the view is
  // made: it may take the earlier keyframes).
  if (unanchored_from_keyframe_id_ >= 0 && reloc.keyframe_id < unanchored_from_keyframe_id_) {
    unanchored_from_keyframe_id_ = -1;
  }
  setReference(reloc.keyframe_id);
  frames_since_keyframe_ = 1;
  reference_inliers_ = reloc.num_inliers;
  result.state = TrackingState::kOk;
  result.relocalized = true;
  result.discontinuous = true;
  result.T_world_camera = T_world_last_;
  result.num_inliers = reloc.num_inliers;
  result.message =
      "relocalised against keyframe " + std::to_string(reloc.keyframe_id) + " after: " + work->aligned.message;
  return true;
}

void RgbdOdometry::markLost(TrackingFrame* work) {
  ++lost_frames_;
  motion_.observe({work->frame.stamp_ns, T_world_last_, /*trusted=*/false, false});
  work->result.state = TrackingState::kLost;
  work->result.message = "lost against keyframe " + std::to_string(reference_id_) + ": " + work->aligned.message;
  if (options_.localization_only) {
    work->result.message += "; localization_only: searching the loaded map by relocalisation";
    return;  // never a new segment: the map must stay as loaded
  }
  if (lost_frames_ >= options_.max_lost_frames && work->enough_to_start) reinitialise(work);
}

void RgbdOdometry::reinitialise(TrackingFrame* work) {
  TrackingResult& result = work->result;
  searching_map_ = false;  // not found in a restored map: a new segment, as after any loss
  // The motion while lost is unknown: the new keyframe's pose is a guess (the last good pose).
  // Until relocalisation or a loop closure ties it to the keyframes from before, the poses are
  // not anchored to the map (TrackingResult::anchored) and nothing downstream trusts them; the
  // segment's tracking view takes none of the earlier keyframes (set before the keyframe is made).
  if (unanchored_from_keyframe_id_ < 0) unanchored_from_keyframe_id_ = next_keyframe_id_;
  addKeyframe(work->frame, work->mask, work->features(), T_world_last_, {}, work->pinhole, &result);
  holdUncompensatedStart(*work);
  if (options_.first_keyframe_moving_hits > 0 && unjudged(work->mask, work->judgement))
    unverified_keyframe_id_ = reference_id_;
  result.state = TrackingState::kOk;
  result.discontinuous = true;
  motion_.observe({work->frame.stamp_ns, T_world_last_, /*trusted=*/true, /*discontinuous=*/true});
  result.message += "; re-initialised after " + std::to_string(lost_frames_) +
                    " lost frames: new keyframe at the last good pose (the motion while lost is "
                    "unknown); poses are not anchored to the map until relocalisation or a loop "
                    "closure";
  lost_frames_ = 0;
}

void RgbdOdometry::holdUncompensatedStart(const TrackingFrame& work) {
  uncompensated_start_.reset();
  if (!(options_.rolling_shutter_readout_ms > 0.0) || reference_id_ < 0) return;
  uncompensated_start_ =
      UncompensatedStart{reference_id_, work.frame.stamp_ns, work.frame.depth_m.clone(), work.frame.camera};
}

void RgbdOdometry::compensateStartKeyframe(TrackingFrame* work) {
  if (!uncompensated_start_) return;
  const UncompensatedStart start = std::move(*uncompensated_start_);
  uncompensated_start_.reset();
  // Only the first frame tracked after the start, against that keyframe, within a few frame
  // intervals (a longer step says less about the turn); only the points the keyframe alone has
  // seen are moved (a re-initialised segment's keyframe may have fused older points).
  constexpr double kMaxStepS = 0.1;
  const double dt_s = timestampToSeconds(work->frame.stamp_ns - start.stamp_ns);
  MapKeyframe* keyframe = map_.mutableKeyframe(start.keyframe_id);
  if (keyframe == nullptr || reference_id_ != start.keyframe_id || pending_ba_.valid() || !(dt_s > 0.0) ||
      dt_s > kMaxStepS) {
    return;
  }
  const CameraRates rates = ratesOfStep(keyframe->T_world_camera.inverse() * work->T_world_camera, dt_s);
  // The skew the turn makes between the top and the bottom row [px]. One step's rotation is
  // uncertain by 0.3-0.5 deg (the first steps of fr1 and Bonn), 3-4 px of skew at 30 Hz: a smaller
  // skew would be remade by noise (the Bonn window's slow start, 2.4 px, remade: 1.04 -> 1.35 cm).
  constexpr double kMinSkewPx = 10.0;
  const double skew_px = rates.omega_rad_s.norm() * options_.rolling_shutter_readout_ms * 1e-3 * work->pinhole.fx;
  if (skew_px < kMinSkewPx) return;
  // The frame was matched against the skewed points, so its own estimate is the difference of
  // the two skews (about none); under constant velocity it turns as the step did.
  work->aligned.rates = rates;
  keyframe->features = compensateRollingShutter(keyframe->features, start.depth_m, start.camera, rates.omega_rad_s,
                                                options_.rolling_shutter_readout_ms * 1e-3, rates.velocity_m_s);
  for (std::size_t i = 0; i < keyframe->map_point_ids.size(); ++i) {
    MapPoint* point = map_.mutablePoint(keyframe->map_point_ids[i]);
    if (point == nullptr || point->first_keyframe_id != keyframe->id || point->observations.size() != 1) continue;
    point->p_world_m = keyframe->T_world_camera * keyframe->features.p_camera_m[i];
  }
  setReference(reference_id_);
}

}  // namespace tracking
}  // namespace dypho
