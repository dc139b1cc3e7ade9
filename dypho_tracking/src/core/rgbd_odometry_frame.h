#pragma once
/// \file rgbd_odometry_frame.h
/// RgbdOdometry's per-frame working state, passed between the steps of RgbdOdometry::track
/// (internal to dypho_tracking_core).

#include <chrono>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/tracking/rgbd_odometry.h"

namespace dypho {
namespace tracking {

/// Milliseconds since `t0` on the steady clock [ms].
inline double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// One frame on its way through RgbdOdometry::track: the call's inputs, then what each step
/// hands to the next. A step reads the fields of the steps before it and writes its own (named
/// under it below); `result` is filled along the way and returned by finishFrame.
struct RgbdOdometry::TrackingFrame {
  TrackingFrame(const RgbdFrame& frame_in, const cv::Mat& mask_in, MaskJudgement judgement_in)
      : t_start(std::chrono::steady_clock::now()), frame(frame_in), mask(mask_in), judgement(judgement_in) {}
  TrackingFrame(const TrackingFrame&) = delete;
  TrackingFrame& operator=(const TrackingFrame&) = delete;

  /// The features of this frame (after prepareFeatures).
  const FrameFeatures& features() const { return prepared->features; }

  // Inputs of track().
  std::chrono::steady_clock::time_point t_start;  ///< when track() began (TrackingTimesMs::total)
  const RgbdFrame& frame;
  const cv::Mat& mask;      ///< CV_8UC1 255 = dynamic, or empty
  MaskJudgement judgement;  ///< whether `mask` judged this frame (the safe start)

  // prepareFeatures.
  Pinhole pinhole;                             ///< the frame's camera
  PreparedFeatures prepared_here;              ///< features prepared in track(), when needed
  const PreparedFeatures* prepared = nullptr;  ///< the caller's or prepared_here
  bool enough_to_start = false;                ///< >= min_init_features keypoints with depth
  bool enough_to_match = false;                ///< >= min_inliers keypoints with depth

  // predictPose (when enough_to_match).
  Eigen::Isometry3d T_world_predicted = Eigen::Isometry3d::Identity();  ///< motion model or last pose

  // matchAndOptimise: the feature pose against the local map, or why there is none.
  AlignmentResult aligned;

  // verifyPose: `aligned` corrected by the static check when moving matches carried it, and
  // its pose as T_world_camera; the camera's turn per frame interval (frameTurnDeg) [deg].
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  double turn_deg = -1.0;

  /// What track() returns; every step adds to it.
  TrackingResult result;
};

}  // namespace tracking
}  // namespace dypho
