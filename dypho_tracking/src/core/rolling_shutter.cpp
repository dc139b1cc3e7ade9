/// First-order rolling-shutter compensation of keypoints (rolling_shutter.h).
#include "dypho/tracking/rolling_shutter.h"

#include <cmath>

#include <Eigen/Geometry>

#include "dypho/tracking/pinhole.h"

namespace dypho {
namespace tracking {

CameraRates ratesOfStep(const Eigen::Isometry3d& T_prev_cur, double dt_s) {
  CameraRates rates;
  if (!(dt_s > 0.0)) return rates;
  const Eigen::AngleAxisd turn(T_prev_cur.rotation());
  rates.omega_rad_s = turn.axis() * turn.angle() / dt_s;
  rates.velocity_m_s = T_prev_cur.rotation().transpose() * T_prev_cur.translation() / dt_s;
  return rates;
}

FrameFeatures compensateRollingShutter(const FrameFeatures& features, const cv::Mat& depth_m,
                                       const CameraIntrinsics& camera, const Eigen::Vector3d& omega_camera_rad_s,
                                       double readout_s, const Eigen::Vector3d& velocity_camera_m_s) {
  FrameFeatures out = features;
  if (!(readout_s > 0.0) || !omega_camera_rad_s.allFinite() || !velocity_camera_m_s.allFinite()) return out;
  const Pinhole pinhole = Pinhole::fromIntrinsics(camera);
  const int rows = depth_m.rows > 0 ? depth_m.rows : camera.height;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const cv::Point2f& pt = out.keypoints[i].pt;
    const double dt_s = rowTimeOffsetS(pt.y, rows, readout_s);
    const Eigen::Vector3d rotation = omega_camera_rad_s * dt_s;
    const double angle = rotation.norm();
    const Eigen::Matrix3d turn =
        angle < 1e-12 ? Eigen::Matrix3d::Identity() : Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix();
    // Seen at the row's time, in the camera of that time; the camera at the stamp sees the same
    // direction rotated by the turn in between: b_stamp = R(omega dt) b_row.
    const Eigen::Vector2d& uv = out.uv_undistorted_px[i];
    const Eigen::Vector3d bearing = turn * pinhole.backProject(uv, 1.0);
    if (bearing.z() < 1e-6) continue;
    const Eigen::Vector2d uv_stamp = pinhole.project(bearing);
    // The depth image holds the scene at the stamp: read it where the keypoint moved to (the
    // same shift in the input image, to first order in the distortion).
    const int u = static_cast<int>(std::lround(pt.x + uv_stamp.x() - uv.x()));
    const int v = static_cast<int>(std::lround(pt.y + uv_stamp.y() - uv.y()));
    if (u >= 0 && v >= 0 && u < depth_m.cols && v < depth_m.rows) {
      const float z = depth_m.at<float>(v, u);
      if (std::isfinite(z) && z > 0.f) out.depth_m[i] = z;
    }
    out.uv_undistorted_px[i] = uv_stamp;
    out.p_camera_m[i] = pinhole.backProject(uv_stamp, out.depth_m[i]);
    // The camera moved by v dt between the row's time and the stamp: p_stamp = p + v dt.
    const Eigen::Vector3d p_stamp = out.p_camera_m[i] + velocity_camera_m_s * dt_s;
    if (p_stamp.z() < 1e-6 || p_stamp == out.p_camera_m[i]) continue;
    out.p_camera_m[i] = p_stamp;
    out.uv_undistorted_px[i] = pinhole.project(p_stamp);
    out.depth_m[i] = static_cast<float>(p_stamp.z());
  }
  return out;
}

}  // namespace tracking
}  // namespace dypho
