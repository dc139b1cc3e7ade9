#include "dypho/mapping/ray_cache.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include <opencv2/calib3d.hpp>

namespace dypho {
namespace mapping {
namespace {}  // namespace

UndistortedRayCache::UndistortedRayCache(std::size_t max_cameras)
    : max_cameras_(std::max<std::size_t>(1, max_cameras)) {}

cv::Mat UndistortedRayCache::computeRays(const CameraIntrinsics& camera) {
  if (!camera.valid()) {
    throw std::invalid_argument("UndistortedRayCache: invalid camera (fx, fy, width and height must be > 0; got fx=" +
                                std::to_string(camera.fx) + " fy=" + std::to_string(camera.fy) + " size " +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height) + ")");
  }
  cv::Mat rays(camera.height, camera.width, CV_32FC2);
  if (!camera.distorted()) {
    for (int v = 0; v < camera.height; ++v) {
      cv::Vec2f* row = rays.ptr<cv::Vec2f>(v);
      const float y = static_cast<float>((v - camera.cy) / camera.fy);
      for (int u = 0; u < camera.width; ++u) {
        row[u] = cv::Vec2f(static_cast<float>((u - camera.cx) / camera.fx), y);
      }
    }
    return rays;
  }
  cv::Mat pixels(camera.height * camera.width, 1, CV_32FC2);
  for (int v = 0, i = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u, ++i) {
      pixels.at<cv::Vec2f>(i) = cv::Vec2f(static_cast<float>(u), static_cast<float>(v));
    }
  }
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const cv::Mat D(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
  cv::Mat undistorted;
  // The default 5 fixed-point iterations leave up to ~0.1 px error for strong radial distortion
  // (e.g. TUM fr1, k3 = 1.16) at the image corners; iterate to convergence instead.
  cv::undistortPoints(pixels, undistorted, K, D, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-6));
  return undistorted.reshape(2, camera.height);
}

std::shared_ptr<const cv::Mat> UndistortedRayCache::rays(const CameraIntrinsics& camera) {
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (sameCamera(it->first, camera)) {
      std::rotate(it, it + 1, entries_.end());  // move to the most-recently-used end
      return entries_.back().second;
    }
  }
  auto table = std::make_shared<const cv::Mat>(computeRays(camera));
  if (entries_.size() >= max_cameras_) entries_.erase(entries_.begin());
  entries_.emplace_back(camera, table);
  return table;
}

}  // namespace mapping
}  // namespace dypho
