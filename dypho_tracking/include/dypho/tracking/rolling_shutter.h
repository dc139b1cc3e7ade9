#pragma once
/// \file rolling_shutter.h
/// First-order rolling-shutter compensation of a frame's keypoints: each image row is exposed at
/// its own time, so under a fast turn the image is skewed. A keypoint seen at row v is moved to
/// where the camera at the frame's stamp would have seen it, by the rotation the camera made in
/// between, and moved by the camera's translation in between when a linear velocity is given.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/camera.h"
#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/rolling_shutter_error.h"

namespace dypho {
namespace tracking {

/// Time of image row `row` (0 = top) relative to the frame's stamp [s]: rows are read out over
/// `readout_s`, the middle row at the stamp.
inline double rowTimeOffsetS(double row, int rows, double readout_s) { return ((row + 0.5) / rows - 0.5) * readout_s; }

/// The camera's velocities during a frame under constant velocity, from one step of the camera
/// `T_prev_cur` (the later camera in the earlier one's frame) over `dt_s` [s]: the angular velocity
/// is the step's rotation vector over dt_s (its axis is the same in both frames), the linear velocity
/// the step's translation in the later camera's frame over dt_s. Zero for dt_s <= 0.
CameraRates ratesOfStep(const Eigen::Isometry3d& T_prev_cur, double dt_s);

/// `features` as a global shutter at the frame's stamp would have seen them: each keypoint's
/// undistorted position is rotated by exp(omega * dt(row)) (omega_camera_rad_s: the camera's
/// angular velocity in its own optical frame [rad/s]; rows read out over readout_s [s]), its depth
/// read again from `depth_m` (registered to the input image, captured at the stamp) where it
/// moved to, and its 3D point made from both; then, with `velocity_camera_m_s` (the camera's
/// linear velocity in its optical frame [m/s]), the point is moved by the camera's translation
/// between its row's time and the stamp and projected again. A keypoint whose new depth is
/// missing keeps its old one. Identity for readout_s <= 0.
FrameFeatures compensateRollingShutter(const FrameFeatures& features, const cv::Mat& depth_m,
                                       const CameraIntrinsics& camera, const Eigen::Vector3d& omega_camera_rad_s,
                                       double readout_s,
                                       const Eigen::Vector3d& velocity_camera_m_s = Eigen::Vector3d::Zero());

}  // namespace tracking
}  // namespace dypho
