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

}  // namespace mask
}  // namespace dypho
