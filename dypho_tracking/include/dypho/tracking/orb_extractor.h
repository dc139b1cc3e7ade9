#pragma once
/// \file orb_extractor.h
/// ORB keypoints on a Gaussian image pyramid, spread over a grid, outside the dynamic mask.

#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// Keypoints and descriptors of one image.
struct OrbFeatures {
  /// Keypoints in level-0 pixel coordinates of the input image [px]; `octave` = pyramid level,
  /// `angle` = orientation [deg], `size` = 31 * scale^level [px], `response` = FAST score.
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;                ///< keypoints.size() x 32, CV_8UC1 (256-bit rBRIEF), row i = keypoint i
  double masked_fraction = 0;         ///< fraction of mask pixels that are dynamic [0, 1]
  int fast_threshold_used = 0;        ///< FAST threshold after the mask relaxation [grey levels]
  double relaxed_threshold_used = 0;  ///< sigma_dy of the relaxed test [fraction of local range]
  int num_relaxed = 0;                ///< keypoints kept from the relaxed test (they follow the FAST ones) [count]
};

/// ORB extractor in the style of ORB-SLAM: per pyramid level a keypoint budget that falls
/// geometrically with the level; one FAST pass per level at `min_fast_threshold`, then per grid
/// cell (`grid_cell_px`) the corners scoring >= `fast_threshold` are used, and the weaker ones
/// only in cells that have no strong corner; cells are served round-robin (best response first) so
/// that the keypoints spread over the image. Orientation by intensity centroid; descriptors by
/// cv::ORB::compute on the same pyramid (same scale factor and level sizes).
///
/// Mask handling: keypoints are only kept where the distance to the nearest dynamic pixel is at
/// least `mask_border_px * scale^level` (level-0 pixels), i.e. the static area is eroded so that
/// descriptors do not straddle the mask border. When part of the image is masked the FAST threshold
/// is relaxed by (1 - mask_threshold_relaxation * masked_fraction). With `relaxed_features`, the
/// budget FAST leaves unfilled on a masked frame goes to the paper's relaxed feature test
/// (relaxed_feature_test.h) in cells with no FAST corner, with the adaptive threshold
/// sigma_dy = relaxed_sigma0 (1 - relaxed_k * masked_fraction) ("Feature Extract"): the fewer
/// static pixels remain, the more low-contrast points qualify.
class OrbExtractor {
 public:
  /// Throws std::invalid_argument when `options.validate()` does.
  explicit OrbExtractor(const TrackingOptions& options);

  /// gray: CV_8UC1 image (at least 64x64). mask: empty (everything static) or CV_8UC1 of the same
  /// size, 255 = dynamic. Throws std::invalid_argument on other types or sizes.
  OrbFeatures extract(const cv::Mat& gray, const cv::Mat& mask);

  /// Scale of pyramid level `level` relative to level 0 (scale_factor^level).
  double levelScale(int level) const { return level_scales_.at(static_cast<size_t>(level)); }

  /// Border kept free of keypoints on every level [px of that level] (ORB patch + orientation disc).
  static constexpr int kEdgePx = 19;

 private:
  TrackingOptions options_;
  std::vector<double> level_scales_;
  std::vector<int> features_per_level_;
  std::vector<int> umax_;  ///< half-widths of the orientation disc per row
  cv::Ptr<cv::ORB> orb_;
};

}  // namespace tracking
}  // namespace dypho
