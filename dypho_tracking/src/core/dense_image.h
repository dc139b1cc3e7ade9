#pragma once
/// \file dense_image.h
/// Image helpers shared by the dense steps of tracking (StaticSceneCheck, DenseRgbdAligner):
/// working-resolution grey, depth and mask, the matching pinhole, bilinear sampling
/// (internal to dypho_tracking_core).

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/static_scene_check.h"

namespace dypho {
namespace tracking {
namespace dense {

/// A depth the dense steps use [m]: finite, in (0.1, 20).
inline bool validDepth(float z) { return z > 0.1f && z < 20.f && std::isfinite(z); }

/// Where bilinear() samples: the top-left pixel and the weights towards the next ones, so that
/// images of one size are sampled at one point without computing them again.
struct BilinearPoint {
  /// (u, v) must lie in [0, cols - 1) x [0, rows - 1) of the images sampled.
  BilinearPoint(double u, double v)
      : x(static_cast<int>(u)), y(static_cast<int>(v)), a(static_cast<float>(u - x)), b(static_cast<float>(v - y)) {}
  /// Bilinear sample of a CV_32FC1 image at this point.
  float sample(const cv::Mat& img) const {
    const float* r0 = img.ptr<float>(y) + x;
    const float* r1 = img.ptr<float>(y + 1) + x;
    return (1.f - b) * ((1.f - a) * r0[0] + a * r0[1]) + b * ((1.f - a) * r1[0] + a * r1[1]);
  }
  int x, y;    ///< top-left pixel
  float a, b;  ///< weights of the right column and the lower row
};

/// Bilinear sample of a CV_32FC1 image; (u, v) must lie in [0, cols - 1) x [0, rows - 1).
inline float bilinear(const cv::Mat& img, double u, double v) { return BilinearPoint(u, v).sample(img); }

/// (u, v) [px] lies where bilinear() may sample `img`.
inline bool insideForBilinear(const cv::Mat& img, double u, double v) {
  return u >= 0.0 && v >= 0.0 && u < img.cols - 1 && v < img.rows - 1;
}

/// The pinhole of `camera` on an image resized by (sx, sy) (pixel centres kept).
inline Pinhole scaledPinhole(const CameraIntrinsics& camera, double sx, double sy) {
  return Pinhole{camera.fx * sx, camera.fy * sy, (camera.cx + 0.5) * sx - 0.5, (camera.cy + 0.5) * sy - 0.5};
}

/// Grey (CV_32F), depth [m] and mask of `frame` reduced by `scale` (a pixel is dynamic when any
/// of the full-resolution pixels under it is), undistorted onto scaledPinhole() when the camera
/// has distortion (`maps` caches the maps per camera). Outside the distorted image there is no
/// depth, and the mask marks it dynamic.
void reduce(const RgbdFrame& frame, const cv::Mat& mask, double scale, UndistortMaps* maps, cv::Mat* grey,
            cv::Mat* depth_m, cv::Mat* mask_small);

/// The pinhole of reduce()'s images of `frame` (`reduced` is one of them).
inline Pinhole reducedPinhole(const RgbdFrame& frame, const cv::Mat& reduced) {
  return scaledPinhole(frame.camera, static_cast<double>(reduced.cols) / frame.bgr.cols,
                       static_cast<double>(reduced.rows) / frame.bgr.rows);
}

/// A small rigid motion exp([v, w]) applied on the left (v [m], w [rad]; rotation by angle-axis).
Eigen::Isometry3d leftStep(const Eigen::Matrix<double, 6, 1>& delta);

/// Median of `values` (reordered; the upper one of an even count); 0 when empty.
inline double median(std::vector<double>* values) {
  if (values->empty()) return 0.0;
  auto mid = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  std::nth_element(values->begin(), mid, values->end());
  return *mid;
}

}  // namespace dense
}  // namespace tracking
}  // namespace dypho
