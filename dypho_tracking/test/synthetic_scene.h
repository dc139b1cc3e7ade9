#pragma once
/// \file synthetic_scene.h
/// Test helpers: a deterministic textured image and a fronto-parallel RGB-D frame.

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/common/types.h"

namespace dypho {
namespace tracking {
namespace test {

/// 640x480 grey image of random filled rectangles and circles (seeded, so identical every run).
inline cv::Mat texturedImage(int seed = 1, int width = 640, int height = 480) {
  cv::RNG rng(static_cast<uint64_t>(seed));
  cv::Mat img(height, width, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i < 700; ++i) {
    const cv::Point c(rng.uniform(0, width), rng.uniform(0, height));
    const int grey = rng.uniform(0, 256);
    if (i % 2 == 0) {
      const cv::Point d(rng.uniform(4, 30), rng.uniform(4, 30));
      cv::rectangle(img, c - d, c + d, cv::Scalar(grey), cv::FILLED);
    } else {
      cv::circle(img, c, rng.uniform(3, 25), cv::Scalar(grey), cv::FILLED, cv::LINE_AA);
    }
  }
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  return img;
}

/// Shifts the image content by (dx, dy) px (integers, replicated border).
inline cv::Mat shifted(const cv::Mat& img, int dx, int dy) {
  cv::Mat out;
  const cv::Matx23d A(1, 0, dx, 0, 1, dy);
  cv::warpAffine(img, out, A, img.size(), cv::INTER_NEAREST, cv::BORDER_REPLICATE);
  return out;
}

/// Undistorted 640x480 camera (fx = fy = 525, TUM ROS default).
inline CameraIntrinsics testCamera() {
  CameraIntrinsics c;
  c.fx = c.fy = 525.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  return c;
}

/// RGB-D frame of `grey` (as BGR) with constant depth `depth_m` (a wall parallel to the image).
inline RgbdFrame planarFrame(const cv::Mat& grey, double depth_m, Timestamp stamp_ns) {
  RgbdFrame f;
  f.stamp_ns = stamp_ns;
  cv::cvtColor(grey, f.bgr, cv::COLOR_GRAY2BGR);
  f.depth_m = cv::Mat(grey.size(), CV_32FC1, cv::Scalar(depth_m));
  f.camera = testCamera();
  return f;
}

}  // namespace test
}  // namespace tracking
}  // namespace dypho
