// Camera effects of the synthetic colour image: motion blur (several ray casts over the exposure)
// and rolling shutter (each image row at its own time). Depth and masks are not affected.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "synthetic_internal.h"

namespace dypho::tools::synth_detail {
namespace {

/// Columns x rows of the grid of pixels whose image motion sets the number of blur samples.
constexpr int kMotionGridCols = 8;
constexpr int kMotionGridRows = 6;
/// Height of a person's chest, the point whose image motion stands for the person's [m].
constexpr double kChestHeightM = 1.2;

/// Pixel of camera-frame point `p` (p.z() > 0).
Eigen::Vector2d project(const CameraIntrinsics& cam, const Eigen::Vector3d& p) {
  return {cam.fx * p.x() / p.z() + cam.cx, cam.fy * p.y() / p.z() + cam.cy};
}

/// Largest image motion [px] of the static scene between the cameras `T_world_start` and
/// `T_world_end`: pixels of a grid at their depth `depth_m` seen from the end camera; infinite
/// when one goes behind the start camera.
double staticImageMotionPx(const CameraIntrinsics& cam, const Eigen::Isometry3d& T_world_start,
                           const Eigen::Isometry3d& T_world_end, const cv::Mat& depth_m) {
  const Eigen::Isometry3d T_start_end = T_world_start.inverse() * T_world_end;
  double max_px = 0.0;
  for (int gy = 0; gy < kMotionGridRows; ++gy) {
    for (int gx = 0; gx < kMotionGridCols; ++gx) {
      const int u = std::min(cam.width - 1, static_cast<int>((gx + 0.5) * cam.width / kMotionGridCols));
      const int v = std::min(cam.height - 1, static_cast<int>((gy + 0.5) * cam.height / kMotionGridRows));
      const double z = depth_m.at<float>(v, u);
      if (!(z > 0.0)) continue;
      const Eigen::Vector3d p_end((u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z);
      const Eigen::Vector3d p_start = T_start_end * p_end;
      if (p_start.z() < 0.05) return std::numeric_limits<double>::infinity();
      max_px = std::max(max_px, (project(cam, p_start) - Eigen::Vector2d(u, v)).norm());
    }
  }
  return max_px;
}

/// Largest image motion [px] of a person's chest between `t0_s` and `t1_s` (people in front of
/// the camera at both times only).
double peopleImageMotionPx(const SceneContent& content, const SynthOptions& o, double t0_s, double t1_s) {
  const Eigen::Isometry3d T_camera_world0 = cameraPoseAt(o, t0_s).inverse();
  const Eigen::Isometry3d T_camera_world1 = cameraPoseAt(o, t1_s).inverse();
  double max_px = 0.0;
  for (const PersonPath& path : content.paths) {
    const Eigen::Vector2d a = personStateAt(path, t0_s).position, b = personStateAt(path, t1_s).position;
    const Eigen::Vector3d pa = T_camera_world0 * Eigen::Vector3d(a.x(), a.y(), kChestHeightM);
    const Eigen::Vector3d pb = T_camera_world1 * Eigen::Vector3d(b.x(), b.y(), kChestHeightM);
    if (pa.z() < 0.1 || pb.z() < 0.1) continue;
    max_px = std::max(max_px, (project(o.camera, pa) - project(o.camera, pb)).norm());
  }
  return max_px;
}

}  // namespace

int blurSampleCount(const SceneContent& content, const SynthOptions& o, double t_s, const cv::Mat& depth_m) {
  if (!(o.exposure_s > 0.0)) return 1;
  const double t0_s = t_s - o.exposure_s;
  const double motion_px = std::max(staticImageMotionPx(o.camera, cameraPoseAt(o, t0_s), cameraPoseAt(o, t_s), depth_m),
                                    peopleImageMotionPx(content, o, t0_s, t_s));
  if (!(motion_px < kMaxBlurSamples)) return kMaxBlurSamples;  // also infinite
  return std::clamp(static_cast<int>(std::ceil(motion_px)), 1, kMaxBlurSamples);
}

double rowTimeOffsetS(const SynthOptions& o, int row) {
  if (!(o.rolling_shutter_s > 0.0)) return 0.0;
  return ((row + 0.5) / o.camera.height - 0.5) * o.rolling_shutter_s;
}

void renderColourWithEffects(const SceneContent& content, const SynthOptions& o, double t_s, int samples,
                             cv::Mat& bgr) {
  const CameraIntrinsics& cam = o.camera;
  bgr.create(cam.height, cam.width, CV_8UC3);
  samples = std::clamp(samples, 1, kMaxBlurSamples);
  const double exposure_s = samples > 1 ? o.exposure_s : 0.0;
  const float inv_samples = 1.f / static_cast<float>(samples);
  cv::parallel_for_(cv::Range(0, cam.height), [&](const cv::Range& rows) {
    std::vector<cv::Vec3f> sum(cam.width);
    for (int v = rows.start; v < rows.end; ++v) {
      std::fill(sum.begin(), sum.end(), cv::Vec3f(0.f, 0.f, 0.f));
      // The row's exposure ends at its rolling-shutter time; samples at the midpoints of N slices.
      const double t_row_s = t_s + rowTimeOffsetS(o, v);
      for (int k = 0; k < samples; ++k) {
        const double t_k_s = t_row_s - (k + 0.5) * exposure_s / samples;
        const RayCastView view = makeRayCastView(content, o, samples > 1 ? t_k_s : t_row_s);
        for (int u = 0; u < cam.width; ++u) sum[u] += castPixel(content, view, cam, u, v).bgr;
      }
      auto* out = bgr.ptr<cv::Vec3b>(v);
      for (int u = 0; u < cam.width; ++u) out[u] = toBgr8(sum[u] * inv_samples);
    }
  });
}

}  // namespace dypho::tools::synth_detail
