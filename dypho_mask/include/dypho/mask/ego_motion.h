#pragma once
/// \file ego_motion.h
/// Camera-induced ("rigid") image motion predicted from depth and a relative pose: where each
/// current pixel of the static scene was in the previous image.

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/camera.h"

namespace dypho {
namespace mask {

/// Rigid correspondence field. For every cell i of `cur_px` (CV_32FC2, a current-image pixel in
/// the undistorted pixel coordinates of `camera`, full resolution) with a valid depth
/// `depth_m(i)` (CV_32FC1 of the same grid size, metres along the optical axis; 0/NaN/negative =
/// none), back-projects X_cur = depth * K^-1 (u, v, 1), maps it with `T_prev_cur` (current camera
/// into previous camera) and projects it with K: `predicted_prev_px(i)` (CV_32FC2, full-res
/// undistorted px). Cells without depth, or whose point lies behind the previous camera
/// (z <= 1 cm), get NaN (no prediction). `camera` must be valid (fx, fy > 0); its distortion is
/// ignored (the inputs are undistorted). Reallocates the output only on a size change.
void predictRigidPrevious(const cv::Mat& cur_px, const cv::Mat& depth_m, const CameraIntrinsics& camera,
                          const Eigen::Isometry3d& T_prev_cur, cv::Mat& predicted_prev_px);

/// Settings of `fitRigidMotion`.
struct RigidFitSettings {
  /// Gauss-Newton iterations, >= 1. Default 10.
  int iterations = 10;
  /// Scale of the Cauchy weights w = 1 / (1 + (r / c)^2) on the first iteration [full-res px];
  /// halved every iteration down to `final_scale_px`, so that a start tens of pixels off still
  /// sees every sample and the end is not pulled by movers. Default 16.
  double initial_scale_px = 16.0;
  /// Scale of the Cauchy weights at the end [full-res px]. Default 1.5.
  double final_scale_px = 1.5;
  /// Every this many cells in x and y are samples, >= 1. Default 2.
  int sample_stride = 2;
  /// Fewest samples (depth, a measured previous position, `usable`) for a fit [count]. Default 60.
  int min_samples = 60;
  /// Prior on the start pose: a deviation that moves the image by this much (translation at the
  /// samples' median depth, rotation) costs as much as every sample 1 px off [px]. It holds the
  /// directions the flow hardly determines (a turn and a sideways move look alike on a distant
  /// wall) against movers; where the flow determines the motion it biases the correction by
  /// about 1 / this^2 (1 %). Default 10.
  double prior_image_motion_px = 10.0;
};

/// Result of `fitRigidMotion`.
struct RigidFit {
  bool ok = false;  ///< enough samples and a finite solution
  Eigen::Isometry3d T_prev_cur = Eigen::Isometry3d::Identity();
  int samples = 0;  ///< samples used
};

/// The relative pose that best explains the measured correspondences: robust Gauss-Newton on
/// the image distance between the rigid prediction (predictRigidPrevious) of each sampled cell
/// of `cur_px` and its measured previous position `measured_prev_px` (CV_32FC2, full-res
/// undistorted px, NaN = none), from `T_start`. Cells where `usable` (CV_8UC1, empty = all) is
/// zero, or without depth, are not sampled. The camera's own motion is what the static majority
/// of the samples agrees on; movers are down-weighted by the Cauchy weights.
RigidFit fitRigidMotion(const cv::Mat& cur_px, const cv::Mat& depth_m, const cv::Mat& measured_prev_px,
                        const cv::Mat& usable, const CameraIntrinsics& camera, const Eigen::Isometry3d& T_start,
                        const RigidFitSettings& settings = RigidFitSettings());

/// Cells of `cur_px` whose rigid prediction under `T_prev_cur` lies within `threshold_px` of the
/// measured previous position (same inputs and sampling as fitRigidMotion) [count].
int countRigidInliers(const cv::Mat& cur_px, const cv::Mat& depth_m, const cv::Mat& measured_prev_px,
                      const cv::Mat& usable, const CameraIntrinsics& camera, const Eigen::Isometry3d& T_prev_cur,
                      double threshold_px, int sample_stride);

}  // namespace mask
}  // namespace dypho
