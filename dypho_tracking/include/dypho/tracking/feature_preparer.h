#pragma once
/// \file feature_preparer.h
/// The part of tracking a frame that does not depend on the map: the input check, the grey image,
/// ORB features outside the mask, undistortion and depth. A caller with a spare core prepares the
/// next frame on another thread while the tracker works on this one and hands the result to
/// RgbdOdometry::track (TrackingNodelet does); without it, track() prepares inline. Both give
/// the same features: the result of tracking does not depend on where they were prepared.

#include <string>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/orb_extractor.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// Empty when `frame` and `mask` can be tracked, otherwise what is wrong and how to fix it
/// (types, sizes, intrinsics; mask empty or CV_8UC1 of the image size, 255 = dynamic).
std::string checkTrackingInput(const RgbdFrame& frame, const cv::Mat& mask);

/// Features of one frame, ready for RgbdOdometry::track.
struct PreparedFeatures {
  Timestamp stamp_ns = 0;  ///< stamp of the frame they were prepared from [ns]
  bool valid = false;      ///< false: the inputs were unusable (track() says why) or nothing was prepared
  OrbFeatures orb;         ///< all keypoints outside the mask, with descriptors
  FrameFeatures features;  ///< those with a depth in [min_depth_m, max_depth_m], undistorted, back-projected
  double ms = 0;           ///< time the preparation took, on the thread that ran it [ms]
};

/// Prepares frames with one ORB extractor. Not thread-safe: one instance per thread.
class FeaturePreparer {
 public:
  /// Throws std::invalid_argument when options.validate() does.
  explicit FeaturePreparer(const TrackingOptions& options);

  /// Never throws on bad data: valid = false when checkTrackingInput finds a problem.
  PreparedFeatures prepare(const RgbdFrame& frame, const cv::Mat& mask);

 private:
  TrackingOptions options_;
  OrbExtractor extractor_;
};

}  // namespace tracking
}  // namespace dypho
