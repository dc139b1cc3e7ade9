#include "dypho/tracking/rgbd_odometry.h"

#include <chrono>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "dypho/tracking/pinhole.h"

namespace dypho {
namespace tracking {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace

RgbdOdometry::RgbdOdometry(const TrackingOptions& options)
    : options_(options),
      extractor_(options),
      aligner_(options),
      selector_(options) {}

void RgbdOdometry::reset() {
  reference_.reset();
  T_world_last_.setIdentity();
  velocity_.setIdentity();
  has_velocity_ = false;
  has_stamp_ = false;
  last_stamp_ns_ = 0;
  frames_since_keyframe_ = 0;
  reference_inliers_ = 0;
  lost_frames_ = 0;
}

std::string RgbdOdometry::checkInput(const RgbdFrame& frame, const cv::Mat& mask) const {
  const cv::Mat& bgr = frame.bgr;
  if (bgr.empty() || (bgr.type() != CV_8UC3 && bgr.type() != CV_8UC1)) {
    return "colour image is empty or not CV_8UC3 (BGR) / CV_8UC1; convert it before tracking";
  }
  if (bgr.cols < 64 || bgr.rows < 64) return "image smaller than 64x64 px";
  if (frame.depth_m.empty() || frame.depth_m.type() != CV_32FC1) {
    return "depth image is empty or not CV_32FC1 metres (16-bit TUM/OpenNI depth: "
           "convertTo(CV_32F, 1/5000.) or 1/1000.)";
  }
  if (frame.depth_m.size() != bgr.size()) {
    return "depth size differs from the colour size; the depth must be registered to the colour "
           "image";
  }
  if (!frame.camera.valid()) return "camera intrinsics invalid (fx, fy, width, height must be > 0)";
  if (frame.camera.width != bgr.cols || frame.camera.height != bgr.rows) {
    return "camera width/height differ from the image size; scale the intrinsics with the image";
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != bgr.size())) {
    return "mask must be empty or CV_8UC1 with the image size (255 = dynamic)";
  }
  return {};
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
    os << "textureless or dark image: only " << orb.keypoints.size()
       << " ORB keypoints (masked fraction " << orb.masked_fraction << ")";
  } else {
    os << "only " << features.size() << " of " << orb.keypoints.size()
       << " keypoints have a valid depth";
  }
  os << "; need " << options_.min_init_features << " keypoints with depth to start";
  return os.str();
}

void RgbdOdometry::startKeyframe(const RgbdFrame& frame, const cv::Mat& mask,
                                 const FrameFeatures& features,
                                 const Eigen::Isometry3d& T_world_camera,
                                 const std::vector<int>& previous_match, TrackingResult* result) {
  reference_ = std::make_shared<const KeyframePoints>(
      makeKeyframePoints(next_keyframe_id_++, frame, mask, T_world_camera, features,
                         reference_.get(), previous_match, &next_map_point_id_));
  frames_since_keyframe_ = 0;
  reference_inliers_ = 0;
  result->is_keyframe = true;
  result->keyframe = reference_->keyframe;
}

TrackingResult RgbdOdometry::track(const RgbdFrame& frame, const cv::Mat& mask) {
  const auto t_start = Clock::now();
  TrackingResult result;
  result.stamp_ns = frame.stamp_ns;
  result.T_world_camera = T_world_last_;
  result.state = reference_ ? TrackingState::kLost : TrackingState::kNotInitialized;
  const auto finish = [&]() -> TrackingResult {
    result.times.total = msSince(t_start);
    return result;
  };

  const std::string problem = checkInput(frame, mask);
  if (!problem.empty()) {
    result.message = "bad input: " + problem;
    if (reference_) {
      ++lost_frames_;
      has_velocity_ = false;
    }
    return finish();
  }
  if (has_stamp_ && frame.stamp_ns <= last_stamp_ns_) {
    std::ostringstream os;
    os << "stamp " << frame.stamp_ns << " ns is not after the previous " << last_stamp_ns_
       << " ns (time jumped backwards or repeated, e.g. a bag restarted): tracker reset, the next "
          "frame starts a new world at identity";
    reset();
    result.message = os.str();
    result.state = TrackingState::kNotInitialized;
    result.T_world_camera.setIdentity();
    has_stamp_ = true;
    last_stamp_ns_ = frame.stamp_ns;
    return finish();
  }
  has_stamp_ = true;
  last_stamp_ns_ = frame.stamp_ns;

  // Features with depth.
  auto t0 = Clock::now();
  cv::Mat gray;
  if (frame.bgr.channels() == 3) {
    cv::cvtColor(frame.bgr, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = frame.bgr;
  }
  const OrbFeatures orb = extractor_.extract(gray, mask);
  const FrameFeatures features = makeFrameFeatures(orb, frame.depth_m, frame.camera,
                                                   options_.min_depth_m, options_.max_depth_m);
  result.times.features = msSince(t0);
  result.num_features = static_cast<int>(features.size());
  result.masked_fraction = orb.masked_fraction;
  const bool enough_to_start = result.num_features >= options_.min_init_features;
  const Pinhole pinhole = Pinhole::fromIntrinsics(frame.camera);

  if (!reference_) {
    if (!enough_to_start) {
      result.message = explainFewFeatures(frame, orb, features);
      return finish();
    }
    startKeyframe(frame, mask, features, T_world_last_, {}, &result);
    result.state = TrackingState::kOk;
    return finish();
  }

  AlignmentResult aligned;
  if (result.num_features >= options_.min_inliers) {
    const Eigen::Isometry3d T_world_predicted =
        has_velocity_ ? T_world_last_ * velocity_ : T_world_last_;
    aligned = aligner_.align(*reference_, features, pinhole, T_world_predicted.inverse(),
                             &result.times);
  } else {
    aligned.message = explainFewFeatures(frame, orb, features);
  }
  const Eigen::Isometry3d T_world_camera = aligned.T_camera_world.inverse();
  if (aligned.success && T_world_camera.matrix().allFinite()) {
    // Velocity only from consecutive good frames.
    has_velocity_ = lost_frames_ == 0;
    velocity_ = T_world_last_.inverse() * T_world_camera;
    T_world_last_ = T_world_camera;
    lost_frames_ = 0;
    ++frames_since_keyframe_;
    if (frames_since_keyframe_ == 1) reference_inliers_ = aligned.num_inliers;
    result.state = TrackingState::kOk;
    result.T_world_camera = T_world_camera;
    result.num_matches = static_cast<int>(aligned.matches.size());
    result.num_inliers = aligned.num_inliers;
    KeyframeQuery query;
    query.T_world_keyframe = reference_->keyframe->T_world_camera;
    query.T_world_camera = T_world_camera;
    query.num_inliers = aligned.num_inliers;
    query.num_reference_inliers = reference_inliers_;
    query.frames_since_keyframe = frames_since_keyframe_;
    // Inter-frame rotation; unknown (0) right after lost frames.
    query.frame_rotation_deg =
        has_velocity_ ? Eigen::AngleAxisd(velocity_.rotation()).angle() * 180.0 / M_PI : 0.0;
    const KeyframeDecision decision = selector_.decide(query);
    if (decision.is_keyframe) {
      std::vector<int> previous_match(features.size(), -1);
      for (size_t m = 0; m < aligned.matches.size(); ++m) {
        if (!aligned.inliers[m]) continue;
        previous_match[static_cast<size_t>(aligned.matches[m].frame_index)] =
            aligned.matches[m].reference_index;
      }
      startKeyframe(frame, mask, features, T_world_camera, previous_match, &result);
    }
    return finish();
  }

  ++lost_frames_;
  has_velocity_ = false;
  result.state = TrackingState::kLost;
  result.message = "lost against keyframe " + std::to_string(reference_->keyframe->id) + ": " +
                   aligned.message;
  if (lost_frames_ >= options_.max_lost_frames && enough_to_start) {
    startKeyframe(frame, mask, features, T_world_last_, {}, &result);
    result.state = TrackingState::kOk;
    result.message += "; re-initialised after " + std::to_string(lost_frames_) +
                      " lost frames: new keyframe at the last good pose (motion while lost is "
                      "not recovered)";
    lost_frames_ = 0;
  }
  return finish();
}

}  // namespace tracking
}  // namespace dypho
