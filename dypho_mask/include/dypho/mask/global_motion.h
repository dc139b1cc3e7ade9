#pragma once
/// \file global_motion.h
/// Camera-induced ("global") image motion as a homography fitted robustly to dense
/// correspondences, and the per-pixel residual once that motion is removed.
///
/// A homography is exact for a rotating camera (H = K R K^-1, in undistorted pixel coordinates)
/// and for a planar or distant scene; for a translating camera in front of a deep scene it is an
/// approximation (parallax remains).

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dypho {
namespace mask {

/// Result of `GlobalMotionEstimator::fit`.
struct GlobalMotionFit {
  bool ok = false;  ///< true when a homography was found with enough inliers
  /// Maps a point of the current image to its position in the previous image, in the units of the
  /// correspondences it was fitted to (homogeneous, H(2,2) = 1).
  cv::Matx33d H_prev_cur = cv::Matx33d::eye();
  int num_samples = 0;  ///< grid samples with finite correspondences
  int num_inliers = 0;  ///< RANSAC inliers among them
  std::string message;  ///< why `ok` is false (empty when ok)

  /// Fraction of samples that are inliers, 0 when there are no samples.
  double inlierRatio() const { return num_samples > 0 ? static_cast<double>(num_inliers) / num_samples : 0.0; }
};

/// Settings of `GlobalMotionEstimator`.
struct GlobalMotionSettings {
  int sample_step = 4;               ///< grid spacing of the samples [grid cells], >= 1
  double ransac_threshold_px = 1.0;  ///< RANSAC inlier threshold [correspondence units], > 0
  int max_iterations = 500;          ///< RANSAC iterations, >= 1
  double min_inlier_ratio = 0.3;     ///< fits with fewer inliers are rejected, in [0, 1)
};

/// Fits the global homography to a dense correspondence field on a grid of samples with RANSAC
/// (cv::findHomography, which refines on the inliers with Levenberg-Marquardt). Keeps its sample
/// buffers between calls.
///
/// Correspondence fields are CV_32FC2 images of equal size (any grid, e.g. the reduced flow
/// resolution): `cur_px(i)` is a point of the current image and `prev_px(i)` the same scene point
/// in the previous image, both in the same pixel units (e.g. undistorted full-resolution pixels).
/// Non-finite entries mean "no correspondence".
class GlobalMotionEstimator {
 public:
  explicit GlobalMotionEstimator(const GlobalMotionSettings& settings);

  /// `usable`: optional CV_8UC1 of the fields' size; only cells where it is non-zero are sampled
  /// (e.g. textured pixels); empty = all. Never throws for bad data: ok = false with a message.
  GlobalMotionFit fit(const cv::Mat& cur_px, const cv::Mat& prev_px, const cv::Mat& usable = cv::Mat());

 private:
  GlobalMotionSettings settings_;
  std::vector<cv::Point2f> src_;
  std::vector<cv::Point2f> dst_;
  std::vector<unsigned char> inliers_;
};

/// Residual motion after removing `H_prev_cur`: residual_px(i) = |prev_px(i) - H cur_px(i)| in the
/// correspondences' units. `residual_px` becomes CV_32FC1 of the fields' size (reallocated only
/// when the size changes); cells without a finite correspondence get 0 (no evidence of motion).
/// `residual_vec_px` (optional): the residual vectors prev - H cur, CV_32FC2 (0 where none).
void computeResidualMagnitude(const cv::Mat& cur_px, const cv::Mat& prev_px, const cv::Matx33d& H_prev_cur,
                              cv::Mat& residual_px, cv::Mat* residual_vec_px = nullptr);

}  // namespace mask
}  // namespace dypho
