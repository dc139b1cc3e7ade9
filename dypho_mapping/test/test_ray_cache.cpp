#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "dypho/mapping/ray_cache.h"

namespace dypho {
namespace mapping {
namespace DYPHO_UNITY_ID {

CameraIntrinsics tumFr1() {
  CameraIntrinsics c;
  c.fx = 517.306408;
  c.fy = 516.469215;
  c.cx = 318.643040;
  c.cy = 255.313989;
  c.width = 640;
  c.height = 480;
  c.distortion = {{0.262383, -0.953104, -0.005358, 0.002628, 1.163314}};
  return c;
}

TEST(UndistortedRayCache, PinholeRaysAreClosedForm) {
  CameraIntrinsics c = tumFr1();
  c.distortion = {{0, 0, 0, 0, 0}};
  const cv::Mat rays = UndistortedRayCache::computeRays(c);
  ASSERT_EQ(rays.size(), cv::Size(640, 480));
  for (const cv::Point& p : {cv::Point(0, 0), cv::Point(100, 50), cv::Point(639, 479)}) {
    const cv::Vec2f r = rays.at<cv::Vec2f>(p);
    // float storage: 1e-6 relative to values of order 1
    EXPECT_NEAR(r[0], (p.x - c.cx) / c.fx, 1e-6);
    EXPECT_NEAR(r[1], (p.y - c.cy) / c.fy, 1e-6);
  }
}

TEST(UndistortedRayCache, DistortedRaysReprojectToTheirPixel) {
  const CameraIntrinsics c = tumFr1();
  const cv::Mat rays = UndistortedRayCache::computeRays(c);
  const cv::Matx33d K(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  const cv::Mat D(1, 5, CV_64F, const_cast<double*>(c.distortion.data()));
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> pixels;
  for (int v = 0; v < c.height; v += 37) {
    for (int u = 0; u < c.width; u += 41) {
      const cv::Vec2f r = rays.at<cv::Vec2f>(v, u);
      object.emplace_back(r[0], r[1], 1.f);
      pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
    }
  }
  std::vector<cv::Point2f> reprojected;
  cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, reprojected);
  double max_err = 0.0, max_shift = 0.0;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    max_err = std::max(max_err, cv::norm(reprojected[i] - pixels[i]));
    const cv::Point2f pinhole(static_cast<float>(object[i].x * c.fx + c.cx),
                              static_cast<float>(object[i].y * c.fy + c.cy));
    max_shift = std::max(max_shift, cv::norm(pinhole - pixels[i]));
  }
  // Iterated to 1e-6 px; 1e-3 px allows for float storage of the rays (1e-7 relative * 500 px).
  EXPECT_LT(max_err, 1e-3);
  // The distortion is real: ignoring it would move corner pixels by several px.
  EXPECT_GT(max_shift, 3.0);
}

TEST(UndistortedRayCache, CachesPerCameraAndEvictsLeastRecentlyUsed) {
  UndistortedRayCache cache(2);
  CameraIntrinsics a = tumFr1();
  CameraIntrinsics b = a;
  b.fx += 1.0;
  CameraIntrinsics c = a;
  c.distortion[0] = 0.0;
  const auto ra = cache.rays(a);
  EXPECT_EQ(cache.rays(a).get(), ra.get());  // same camera -> same table
  const auto rb = cache.rays(b);
  EXPECT_NE(rb.get(), ra.get());
  EXPECT_EQ(cache.size(), 2u);
  cache.rays(a);  // a is now the most recently used
  cache.rays(c);  // evicts b
  EXPECT_EQ(cache.size(), 2u);
  EXPECT_EQ(cache.rays(a).get(), ra.get());
  EXPECT_NE(cache.rays(b).get(), rb.get());  // recomputed after eviction
  EXPECT_EQ(cv::norm(*cache.rays(b), *rb, cv::NORM_INF), 0.0);
}

TEST(UndistortedRayCache, InvalidCameraThrows) {
  UndistortedRayCache cache;
  EXPECT_THROW(cache.rays(CameraIntrinsics()), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace mapping
}  // namespace dypho
