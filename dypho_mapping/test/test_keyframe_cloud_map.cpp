#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <pcl/io/pcd_io.h>
#include <unistd.h>

#include "dypho/mapping/keyframe_cloud_map.h"

namespace dypho {
namespace mapping {
namespace DYPHO_UNITY_ID {

namespace fs = std::filesystem;

CameraIntrinsics pinhole(int width, int height) {
  CameraIntrinsics c;
  c.fx = 525.0;
  c.fy = 520.0;
  c.cx = width / 2.0 - 0.5;
  c.cy = height / 2.0 + 3.25;
  c.width = width;
  c.height = height;
  return c;
}

/// Keyframe with constant depth and colour, no mask.
Keyframe makeKeyframe(std::int64_t id, const CameraIntrinsics& camera, float depth_m,
                      const cv::Vec3b& bgr = cv::Vec3b(10, 20, 30),
                      const Eigen::Isometry3d& T_world_camera = Eigen::Isometry3d::Identity()) {
  Keyframe kf;
  kf.id = id;
  kf.frame.camera = camera;
  kf.frame.bgr = cv::Mat(camera.height, camera.width, CV_8UC3, cv::Scalar(bgr[0], bgr[1], bgr[2]));
  kf.frame.depth_m = cv::Mat(camera.height, camera.width, CV_32FC1, cv::Scalar(depth_m));
  kf.T_world_camera = T_world_camera;
  return kf;
}

CloudMapOptions options(int stride, double voxel_m) {
  CloudMapOptions o;
  o.pixel_stride = stride;
  o.voxel_size_m = voxel_m;
  return o;
}

Eigen::Isometry3d pose(double tx, double ty, double tz, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(tx, ty, tz);
  return T;
}

TEST(KeyframeCloudMap, SinglePixelMatchesClosedFormUnprojection) {
  const CameraIntrinsics cam = pinhole(64, 48);
  KeyframeCloudMap map(options(1, 0.0));
  Keyframe kf = makeKeyframe(0, cam, 0.f);
  kf.frame.depth_m.at<float>(20, 10) = 2.0f;  // row 20, column 10
  kf.frame.bgr.at<cv::Vec3b>(20, 10) = cv::Vec3b(1, 2, 3);
  kf.T_world_camera = pose(0.5, -1.0, 2.0, 0.3);
  ASSERT_EQ(map.addKeyframe(kf), 1u);
  const auto cloud = map.buildCloud();
  ASSERT_EQ(cloud->size(), 1u);
  const Eigen::Vector3d p_camera(2.0 * (10 - cam.cx) / cam.fx, 2.0 * (20 - cam.cy) / cam.fy, 2.0);
  const Eigen::Vector3d expected = kf.T_world_camera * p_camera;
  const auto& p = cloud->front();
  // float storage of a few-metre coordinate: 1e-5 m
  EXPECT_NEAR(p.x, expected.x(), 1e-5);
  EXPECT_NEAR(p.y, expected.y(), 1e-5);
  EXPECT_NEAR(p.z, expected.z(), 1e-5);
  EXPECT_EQ(p.b, 1);
  EXPECT_EQ(p.g, 2);
  EXPECT_EQ(p.r, 3);
}

TEST(KeyframeCloudMap, DistortedCameraMatchesUndistortPoints) {
  CameraIntrinsics cam = pinhole(640, 480);
  cam.distortion = {{0.262383, -0.953104, -0.005358, 0.002628, 1.163314}};  // TUM fr1
  const int stride = 16;
  const float depth = 1.5f;
  KeyframeCloudMap map(options(stride, 0.0));
  ASSERT_EQ(map.addKeyframe(makeKeyframe(0, cam, depth)), 40u * 30u);
  const auto cloud = map.buildCloud();  // identity pose: world = camera, insertion order kept

  std::vector<cv::Point2f> pixels;
  for (int v = 0; v < cam.height; v += stride)
    for (int u = 0; u < cam.width; u += stride) pixels.emplace_back(u, v);
  const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  const cv::Mat D(1, 5, CV_64F, cam.distortion.data());
  std::vector<cv::Point2f> normalised;
  cv::undistortPoints(pixels, normalised, K, D, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-6));
  ASSERT_EQ(cloud->size(), normalised.size());
  double max_err = 0.0, max_pinhole_err = 0.0;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const auto& p = (*cloud)[i];
    max_err = std::max({max_err, double(std::abs(p.x - depth * normalised[i].x)),
                        double(std::abs(p.y - depth * normalised[i].y)), double(std::abs(p.z - depth))});
    max_pinhole_err = std::max(max_pinhole_err, std::abs(p.x - depth * (pixels[i].x - cam.cx) / cam.fx));
  }
  // Same algorithm and criteria as cv::undistortPoints: equal up to float rounding (1e-6 m).
  EXPECT_LT(max_err, 1e-6);
  // The default cv::undistortPoints (5 iterations) agrees to within ~1 mm at 1.5 m; ignoring the
  // distortion altogether would be off by more than 1 cm at the corners.
  std::vector<cv::Point2f> default_iter;
  cv::undistortPoints(pixels, default_iter, K, D);
  double max_default = 0.0;
  for (std::size_t i = 0; i < pixels.size(); ++i)
    max_default = std::max(max_default, depth * cv::norm(default_iter[i] - normalised[i]));
  std::printf(
      "[ report ] distorted unprojection: default 5-iteration undistortPoints differs by "
      "up to %.2e m at 1.5 m; pinhole would be off by %.3f m\n",
      max_default, max_pinhole_err);
  EXPECT_LT(max_default, 1e-3);
  EXPECT_GT(max_pinhole_err, 0.01);
}

TEST(KeyframeCloudMap, MaskedAndInvalidPixelsAreExcludedExactly) {
  const CameraIntrinsics cam = pinhole(64, 48);
  KeyframeCloudMap map(options(2, 0.0));  // 32 x 24 = 768 samples
  Keyframe kf = makeKeyframe(0, cam, 1.0f);
  kf.mask = cv::Mat::zeros(48, 64, CV_8UC1);
  kf.mask(cv::Rect(0, 0, 20, 20)).setTo(255);  // 10 x 10 samples dynamic
  kf.mask.at<uchar>(41, 41) = 255;             // odd pixel: not sampled, must not matter
  cv::Mat& d = kf.frame.depth_m;
  d.at<float>(30, 30) = std::numeric_limits<float>::quiet_NaN();
  d.at<float>(30, 32) = 0.f;    // no measurement
  d.at<float>(30, 34) = 5.0f;   // > max_depth_m (4)
  d.at<float>(30, 36) = 0.05f;  // < min_depth_m (0.1)
  d.at<float>(30, 38) = std::numeric_limits<float>::infinity();
  d.at<float>(4, 4) = std::numeric_limits<float>::quiet_NaN();  // already masked
  EXPECT_EQ(map.addKeyframe(kf), 768u - 100u - 5u);
  EXPECT_EQ(map.numPoints(), 663u);
  // Boundary depths are inclusive.
  KeyframeCloudMap edge(options(2, 0.0));
  EXPECT_EQ(edge.addKeyframe(makeKeyframe(1, cam, 4.0f)), 768u);
}

TEST(KeyframeCloudMap, ReanchoringMovesExactlyThatKeyframe) {
  const CameraIntrinsics cam = pinhole(32, 24);
  KeyframeCloudMap map(options(4, 0.0));
  const cv::Vec3b red(0, 0, 255), green(0, 255, 0);
  map.addKeyframe(makeKeyframe(1, cam, 1.0f, red, pose(0, 0, 0, 0)));
  map.addKeyframe(makeKeyframe(2, cam, 2.0f, green, pose(5, 0, 0, 0.2)));
  const auto before = map.buildCloud();
  const Eigen::Isometry3d old_pose = pose(5, 0, 0, 0.2);
  const Eigen::Isometry3d new_pose = pose(5, 1, -2, -0.4);
  EXPECT_TRUE(map.updateKeyframePose(2, new_pose));
  EXPECT_FALSE(map.updateKeyframePose(99, new_pose));
  const auto after = map.buildCloud();
  ASSERT_EQ(before->size(), after->size());
  std::size_t moved = 0;
  for (std::size_t i = 0; i < before->size(); ++i) {
    const auto& a = (*before)[i];
    const auto& b = (*after)[i];
    const Eigen::Vector3d pa(a.x, a.y, a.z), pb(b.x, b.y, b.z);
    ASSERT_EQ(a.g, b.g);
    if (a.g == 255) {  // keyframe 2: new = T_new * T_old^-1 * old
      const Eigen::Vector3d expected = new_pose * (old_pose.inverse() * pa);
      EXPECT_LT((pb - expected).norm(), 1e-5);  // float coordinates of ~6 m
      ++moved;
    } else {
      EXPECT_EQ(pa, pb);  // keyframe 1 untouched, bit for bit
    }
  }
  EXPECT_EQ(moved, 8u * 6u);
  EXPECT_THROW(map.updateKeyframePose(1, pose(std::nan(""), 0, 0, 0)), std::invalid_argument);
}

TEST(KeyframeCloudMap, VoxelFilterBoundsTheCount) {
  const CameraIntrinsics cam = pinhole(640, 480);
  const double leaf = 0.05;
  KeyframeCloudMap map(options(1, leaf));
  ASSERT_EQ(map.addKeyframe(makeKeyframe(0, cam, 1.0f)), 640u * 480u);
  CloudBuildReport report;
  const auto cloud = map.buildCloud(&report);
  EXPECT_EQ(report.input_points, 640u * 480u);
  EXPECT_EQ(report.output_points, cloud->size());
  EXPECT_FALSE(report.coarser_leaf);
  EXPECT_DOUBLE_EQ(report.leaf_size_m, leaf);
  // A plane at z = 1 m spanning (640 / fx) x (480 / fy) m occupies at most this many voxels.
  const double cells = (std::floor(640.0 / cam.fx / leaf) + 2) * (std::floor(480.0 / cam.fy / leaf) + 2);
  EXPECT_LE(static_cast<double>(cloud->size()), cells);
  EXPECT_GT(cloud->size(), cells / 4);  // and it is not collapsed to a few points
  // Averaged colour of a uniformly coloured keyframe stays that colour.
  EXPECT_EQ(cloud->front().r, 30);
  EXPECT_EQ(cloud->front().b, 10);
}

TEST(KeyframeCloudMap, HugeExtentFallsBackToCoarserLeaf) {
  const CameraIntrinsics cam = pinhole(64, 48);
  KeyframeCloudMap map(options(4, 0.001));
  map.addKeyframe(makeKeyframe(0, cam, 1.0f, cv::Vec3b(0, 0, 255), pose(0, 0, 0, 0)));
  map.addKeyframe(makeKeyframe(1, cam, 1.0f, cv::Vec3b(0, 255, 0), pose(2000, 2000, 2000, 0)));
  CloudBuildReport report;
  const auto cloud = map.buildCloud(&report);
  EXPECT_TRUE(report.coarser_leaf);
  EXPECT_GT(report.leaf_size_m, 0.001);
  EXPECT_NE(report.message.find("overflow"), std::string::npos) << report.message;
  // Both far-apart keyframes are still in the filtered cloud.
  bool near_origin = false, far_away = false;
  for (const auto& p : *cloud) {
    near_origin |= std::abs(p.x) < 10;
    far_away |= std::abs(p.x - 2000) < 10;
  }
  EXPECT_TRUE(near_origin && far_away);
}

TEST(KeyframeCloudMap, PcdRoundTripIsAtomic) {
  const fs::path dir = fs::temp_directory_path() / ("dypho_pcd_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const CameraIntrinsics cam = pinhole(64, 48);
  KeyframeCloudMap map(options(2, 0.0));
  Keyframe kf = makeKeyframe(0, cam, 1.5f);
  cv::randu(kf.frame.bgr, cv::Scalar::all(0), cv::Scalar::all(256));
  map.addKeyframe(kf);
  const std::string path = (dir / "map.pcd").string();
  map.savePcd(path);
  map.savePcd(path);  // overwriting an existing file works too

  pcl::PointCloud<pcl::PointXYZRGB> loaded;
  ASSERT_EQ(pcl::io::loadPCDFile(path, loaded), 0);
  const auto built = map.buildCloud();
  ASSERT_EQ(loaded.size(), built->size());
  for (std::size_t i = 0; i < loaded.size(); ++i) {
    EXPECT_EQ(loaded[i].rgba, (*built)[i].rgba);
    EXPECT_EQ(loaded[i].x, (*built)[i].x);  // binary PCD: bit-exact floats
  }
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "map.pcd") << "left behind: " << entry.path();
  }
  EXPECT_EQ(files, 1u);

  const std::string bad = (dir / "missing_folder" / "map.pcd").string();
  try {
    map.savePcd(bad);
    ADD_FAILURE() << "saving into a missing folder did not throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(KeyframeCloudMap, BadKeyframesThrowInvalidArgument) {
  const CameraIntrinsics cam = pinhole(64, 48);
  KeyframeCloudMap map(options(2, 0.0));
  Keyframe nan_pose = makeKeyframe(0, cam, 1.0f);
  nan_pose.T_world_camera.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(map.addKeyframe(nan_pose), std::invalid_argument);
  Keyframe scaled = makeKeyframe(0, cam, 1.0f);
  scaled.T_world_camera.linear() *= 2.0;
  EXPECT_THROW(map.addKeyframe(scaled), std::invalid_argument);
  Keyframe empty = makeKeyframe(0, cam, 1.0f);
  empty.frame.depth_m.release();
  EXPECT_THROW(map.addKeyframe(empty), std::invalid_argument);
  Keyframe mismatched = makeKeyframe(0, cam, 1.0f);
  mismatched.frame.depth_m = cv::Mat::ones(24, 32, CV_32FC1);
  EXPECT_THROW(map.addKeyframe(mismatched), std::invalid_argument);
  Keyframe bad_mask = makeKeyframe(0, cam, 1.0f);
  bad_mask.mask = cv::Mat::zeros(24, 32, CV_8UC1);
  EXPECT_THROW(map.addKeyframe(bad_mask), std::invalid_argument);
  Keyframe mm_depth = makeKeyframe(0, cam, 1.0f);
  mm_depth.frame.depth_m.convertTo(mm_depth.frame.depth_m, CV_16UC1);
  EXPECT_THROW(map.addKeyframe(mm_depth), std::invalid_argument);
  Keyframe no_id = makeKeyframe(-1, cam, 1.0f);
  EXPECT_THROW(map.addKeyframe(no_id), std::invalid_argument);
  Keyframe wrong_camera = makeKeyframe(0, pinhole(32, 24), 1.0f);
  wrong_camera.frame.camera = cam;
  EXPECT_THROW(map.addKeyframe(wrong_camera), std::invalid_argument);
  EXPECT_EQ(map.numKeyframes(), 0u);
  EXPECT_EQ(map.numPoints(), 0u);
}

TEST(KeyframeCloudMap, CapacityCapKeepsOldestAndSkipsNewest) {
  const CameraIntrinsics cam = pinhole(64, 48);
  CloudMapOptions o = options(2, 0.0);
  o.max_points = 1000;  // one keyframe is 768 points
  KeyframeCloudMap map(o);
  EXPECT_EQ(map.addKeyframe(makeKeyframe(1, cam, 1.0f)), 768u);
  EXPECT_FALSE(map.capacityReached());
  EXPECT_EQ(map.addKeyframe(makeKeyframe(2, cam, 1.0f)), 0u);
  EXPECT_TRUE(map.capacityReached());
  EXPECT_EQ(map.numKeyframes(), 1u);
  EXPECT_EQ(map.numPoints(), 768u);
  EXPECT_FALSE(map.updateKeyframePose(2, Eigen::Isometry3d::Identity()));  // skipped = unknown
  // Re-adding an existing id replaces it (no growth), and fits.
  EXPECT_EQ(map.addKeyframe(makeKeyframe(1, cam, 1.0f)), 768u);
  EXPECT_EQ(map.numKeyframes(), 1u);
  EXPECT_EQ(map.numPoints(), 768u);
  for (int i = 3; i < 20; ++i) map.addKeyframe(makeKeyframe(i, cam, 1.0f));
  EXPECT_LE(map.numPoints(), o.max_points);
  map.reset();
  EXPECT_EQ(map.numKeyframes(), 0u);
  EXPECT_EQ(map.numPoints(), 0u);
  EXPECT_FALSE(map.capacityReached());
}

}  // namespace DYPHO_UNITY_ID
}  // namespace mapping
}  // namespace dypho
