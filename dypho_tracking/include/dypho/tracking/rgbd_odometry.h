#pragma once
/// \file rgbd_odometry.h
/// Frame-to-keyframe RGB-D visual odometry: the public entry point of dypho_tracking_core.

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/keyframe_aligner.h"
#include "dypho/tracking/keyframe_points.h"
#include "dypho/tracking/keyframe_selector.h"
#include "dypho/tracking/orb_extractor.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {

/// RGB-D visual odometry against the last keyframe.
///
/// Per frame: ORB features outside the dynamic mask (OrbExtractor) -> undistort + depth
/// (makeFrameFeatures) -> pose against the last keyframe's 3D world points (KeyframeAligner:
/// constant-velocity prediction, guided matching, PnP RANSAC fallback, Ceres refinement) ->
/// KeyframeSelector. Tracking against the keyframe (not the previous frame) avoids accumulating
/// the error of every frame; only keyframe-to-keyframe errors add up.
///
/// State machine:
///  - NOT_INITIALIZED: the first frame with >= min_init_features keypoints with depth becomes
///    keyframe 0 at T_world_camera = identity (this frame returns OK, is_keyframe).
///  - OK: frame registered; may become a keyframe.
///  - LOST: registration failed; the last good pose is returned, the velocity is dropped and the
///    next frame is again aligned to the same keyframe (prediction = last good pose, with the PnP
///    fallback). After max_lost_frames consecutive failures, the next frame with enough features
///    becomes a new keyframe at the last good pose (re-initialisation; the trajectory continues
///    from there but the jump during the lost frames is not recovered).
///  - A stamp not after the previous one (time going backwards or repeated) resets everything:
///    NOT_INITIALIZED, identity pose, message; the following frame starts a new world.
///
/// Not thread-safe: call `track` from one thread.
class RgbdOdometry {
 public:
  /// Throws std::invalid_argument when options.validate() does.
  explicit RgbdOdometry(const TrackingOptions& options);

  /// mask: CV_8UC1 255 = dynamic (no features there), or empty = all static. Never throws on
  /// bad data: returns a result with state kLost/kNotInitialized and a message (no valid depth,
  /// all masked, textureless, wrong types/sizes, stamp not after the previous one -> reset +
  /// message). Never returns a NaN pose.
  TrackingResult track(const RgbdFrame& frame, const cv::Mat& mask);

  /// Forgets keyframe, pose and velocity; the next usable frame starts a new world at identity.
  /// Keyframe and map-point ids keep increasing (unique over the object's life).
  void reset();

  /// The options in use.
  const TrackingOptions& options() const { return options_; }

 private:
  /// Empty when the inputs are usable, otherwise what is wrong and how to fix it.
  std::string checkInput(const RgbdFrame& frame, const cv::Mat& mask) const;
  /// Explains why a frame has too few keypoints with depth.
  std::string explainFewFeatures(const RgbdFrame& frame, const OrbFeatures& orb,
                                 const FrameFeatures& features) const;
  /// Makes `features` the new reference keyframe at T_world_camera and fills the result fields.
  void startKeyframe(const RgbdFrame& frame, const cv::Mat& mask, const FrameFeatures& features,
                     const Eigen::Isometry3d& T_world_camera,
                     const std::vector<int>& previous_match, TrackingResult* result);

  TrackingOptions options_;
  OrbExtractor extractor_;
  KeyframeAligner aligner_;
  KeyframeSelector selector_;

  /// Keyframe tracked against; null before initialisation.
  std::shared_ptr<const KeyframePoints> reference_;
  Eigen::Isometry3d T_world_last_ = Eigen::Isometry3d::Identity();  ///< last good pose
  Eigen::Isometry3d velocity_ = Eigen::Isometry3d::Identity();  ///< T_previous_last (camera motion)
  bool has_velocity_ = false;
  bool has_stamp_ = false;
  Timestamp last_stamp_ns_ = 0;
  int frames_since_keyframe_ = 0;
  int reference_inliers_ = 0;  ///< inliers of the first frame tracked against the keyframe
  int lost_frames_ = 0;
  std::int64_t next_keyframe_id_ = 0;
  std::int64_t next_map_point_id_ = 0;
};

}  // namespace tracking
}  // namespace dypho
