#pragma once
/// \file tracking_result.h
/// What `RgbdOdometry::track` returns for one frame.

#include <string>

#include <Eigen/Geometry>

#include "dypho/common/types.h"

namespace dypho {
namespace tracking {

/// State of the tracker after a frame.
enum class TrackingState {
  kNotInitialized,  ///< no keyframe yet (first frames, after reset, or unusable first frame)
  kOk,              ///< pose estimated for this frame
  kLost,            ///< a keyframe exists but this frame could not be registered to it
};

/// "NOT_INITIALIZED", "OK" or "LOST".
const char* toString(TrackingState state);

/// Wall-clock time spent in each stage of `track` [ms].
struct TrackingTimesMs {
  double features = 0;  ///< ORB extraction, undistortion and depth look-up [ms]
  double matching = 0;  ///< descriptor matching, guided and brute force [ms]
  double pnp = 0;       ///< PnP RANSAC (0 when the motion prediction was good enough) [ms]
  double refine = 0;    ///< Ceres motion-only refinement, all passes [ms]
  double total = 0;     ///< whole `track` call [ms]
};

/// Result of tracking one frame.
struct TrackingResult {
  Timestamp stamp_ns = 0;                       ///< stamp of the frame [ns]
  TrackingState state = TrackingState::kNotInitialized;  ///< tracker state after this frame
  /// Camera optical frame in the world frame (world = first keyframe). When not kOk: the last good
  /// pose (identity before initialisation). Always finite.
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool is_keyframe = false;  ///< this frame became a new keyframe
  int num_features = 0;      ///< keypoints with valid depth in this frame [count]
  int num_matches = 0;       ///< keyframe-to-frame matches used for the final pose [count]
  int num_inliers = 0;       ///< pose inliers after the chi2 outlier rounds [count]
  double masked_fraction = 0;  ///< fraction of pixels marked dynamic in the mask [0, 1]
  KeyframeConstPtr keyframe;   ///< the new keyframe; non-null exactly when is_keyframe
  std::string message;         ///< why LOST / NOT_INITIALIZED / reset; empty when all went well
  TrackingTimesMs times;       ///< stage timings [ms]
};

}  // namespace tracking
}  // namespace dypho
