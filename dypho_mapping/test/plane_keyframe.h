#pragma once
/// \file plane_keyframe.h
/// Test helper: a keyframe of a textured fronto-parallel plane at 2 m (checkerboard in blue, a
/// horizontal ramp in red), centred principal point.

#include <cstdint>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/mapping/gaussian_mapper.h"

namespace dypho::mapping::test {

inline Keyframe texturedPlaneKeyframe(std::int64_t id, const Eigen::Isometry3d& T_world_camera,
                                      int width_px, int height_px, double focal_px, int checker_px) {
  Keyframe kf;
  kf.id = id;
  CameraIntrinsics& c = kf.frame.camera;
  c.width = width_px;
  c.height = height_px;
  c.fx = c.fy = focal_px;
  c.cx = (width_px - 1) / 2.0;
  c.cy = (height_px - 1) / 2.0;
  kf.frame.bgr.create(height_px, width_px, CV_8UC3);
  for (int v = 0; v < height_px; ++v) {
    for (int u = 0; u < width_px; ++u) {
      const int checker = (u / checker_px + v / checker_px) % 2;
      kf.frame.bgr.at<cv::Vec3b>(v, u) =
          cv::Vec3b(static_cast<uchar>(checker * 150 + 50), 120, static_cast<uchar>(2 * u));
    }
  }
  kf.frame.depth_m = cv::Mat(height_px, width_px, CV_32FC1, cv::Scalar(2.f));
  kf.T_world_camera = T_world_camera;
  return kf;
}

}  // namespace dypho::mapping::test
