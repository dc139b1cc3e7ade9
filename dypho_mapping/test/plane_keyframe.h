#pragma once
/// \file plane_keyframe.h
/// Test helper: a keyframe of a textured fronto-parallel plane at 2 m (checkerboard in blue, a
/// horizontal ramp in red), centred principal point. The texture is fixed on the plane: a camera
/// translated sideways (x, y of `T_world_camera`) sees it shifted, so keyframes taken from
/// translated poses are views of one scene. Rotations are not modelled (the plane stays at 2 m in
/// front of each camera).

#include <cmath>
#include <cstdint>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/mapping/gaussian_mapper.h"

namespace dypho::mapping::test {

inline Keyframe texturedPlaneKeyframe(std::int64_t id, const Eigen::Isometry3d& T_world_camera, int width_px,
                                      int height_px, double focal_px, int checker_px) {
  Keyframe kf;
  kf.id = id;
  CameraIntrinsics& c = kf.frame.camera;
  c.width = width_px;
  c.height = height_px;
  c.fx = c.fy = focal_px;
  c.cx = (width_px - 1) / 2.0;
  c.cy = (height_px - 1) / 2.0;
  constexpr double kPlaneDepthM = 2.0;
  // Pixel shift of the texture: where this camera's pixel lies on the plane, in the pixels of a
  // camera at the world origin (exactly 0 for the identity pose).
  const double shift_u_px = focal_px * T_world_camera.translation().x() / kPlaneDepthM;
  const double shift_v_px = focal_px * T_world_camera.translation().y() / kPlaneDepthM;
  kf.frame.bgr.create(height_px, width_px, CV_8UC3);
  for (int v = 0; v < height_px; ++v) {
    for (int u = 0; u < width_px; ++u) {
      const double u_plane = u + shift_u_px, v_plane = v + shift_v_px;
      const long cell =
          static_cast<long>(std::floor(u_plane / checker_px)) + static_cast<long>(std::floor(v_plane / checker_px));
      const int checker = static_cast<int>(((cell % 2) + 2) % 2);
      const long red = ((static_cast<long>(std::lround(2.0 * u_plane)) % 256) + 256) % 256;  // a ramp that wraps
      kf.frame.bgr.at<cv::Vec3b>(v, u) =
          cv::Vec3b(static_cast<uchar>(checker * 150 + 50), 120, static_cast<uchar>(red));
    }
  }
  kf.frame.depth_m = cv::Mat(height_px, width_px, CV_32FC1, cv::Scalar(kPlaneDepthM));
  kf.T_world_camera = T_world_camera;
  return kf;
}

/// Mapper options for the plane keyframes: training at full resolution, dense coverage seeds, no
/// feature samples. Nice only, not the idle class: the worker tests wait for training against the
/// wall clock, and in the idle class a test running beside them (ctest -j) could hold the training
/// off altogether (GaussianMapper.TrainingThreadsRunInTheIdleClass checks the class).
inline GaussianMapperOptions smallMapperOptions() {
  GaussianMapperOptions o;
  o.train_downsample = 1;
  o.coverage_stride_px = 4;
  o.feature_samples = 0;
  o.training_idle_class = false;
  return o;
}

}  // namespace dypho::mapping::test
