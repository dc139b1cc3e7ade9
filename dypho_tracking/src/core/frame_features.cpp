#include "dypho/tracking/frame_features.h"

#include <cmath>

#include <opencv2/calib3d.hpp>

#include "dypho/tracking/pinhole.h"

namespace dypho {
namespace tracking {

std::vector<Eigen::Vector2d> undistortPixels(const std::vector<cv::Point2f>& distorted_px,
                                             const CameraIntrinsics& camera) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(distorted_px.size());
  if (distorted_px.empty()) return out;
  if (!camera.distorted()) {
    for (const auto& p : distorted_px) out.emplace_back(p.x, p.y);
    return out;
  }
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
  std::vector<cv::Point2f> undistorted;
  // The default 5 iterations are not enough for fr1's strong radial terms near the corners.
  cv::undistortPoints(distorted_px, undistorted, K, dist, cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 20, 0.0));
  for (const auto& p : undistorted) out.emplace_back(p.x, p.y);
  return out;
}

FrameFeatures makeFrameFeatures(const OrbFeatures& orb, const cv::Mat& depth_m, const CameraIntrinsics& camera,
                                double min_depth_m, double max_depth_m) {
  FrameFeatures out;
  out.image_rows = depth_m.rows;
  const size_t n = orb.keypoints.size();
  std::vector<int> keep;
  std::vector<float> depths;
  keep.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f& p = orb.keypoints[i].pt;
    const int u = cvRound(p.x), v = cvRound(p.y);
    if (u < 0 || v < 0 || u >= depth_m.cols || v >= depth_m.rows) continue;
    const float d = depth_m.at<float>(v, u);
    if (!std::isfinite(d) || d < min_depth_m || d > max_depth_m) continue;
    keep.push_back(static_cast<int>(i));
    depths.push_back(d);
  }
  std::vector<cv::Point2f> distorted;
  distorted.reserve(keep.size());
  for (int i : keep) distorted.push_back(orb.keypoints[static_cast<size_t>(i)].pt);
  out.uv_undistorted_px = undistortPixels(distorted, camera);

  const Pinhole pinhole = Pinhole::fromIntrinsics(camera);
  out.keypoints.reserve(keep.size());
  out.p_camera_m.reserve(keep.size());
  out.descriptors.create(static_cast<int>(keep.size()), 32, CV_8UC1);
  for (size_t k = 0; k < keep.size(); ++k) {
    const int i = keep[k];
    out.keypoints.push_back(orb.keypoints[static_cast<size_t>(i)]);
    out.p_camera_m.push_back(pinhole.backProject(out.uv_undistorted_px[k], depths[k]));
    orb.descriptors.row(i).copyTo(out.descriptors.row(static_cast<int>(k)));
  }
  out.depth_m = std::move(depths);
  return out;
}

}  // namespace tracking
}  // namespace dypho
