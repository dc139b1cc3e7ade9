/// Accuracy and timing of RgbdOdometry on the real sequences in DYPHO_SHARED_DIR/data:
/// TUM fr1/rpy (first 150 frames, static, strong rotation, distorted camera) and Bonn
/// rgbd_bonn_crowd frames 200-399 (people walking, no dynamic mask given here).
/// Skips (with a message) when the data folder is absent.
/// Set DYPHO_TRACKING_TRAJ_DIR=<folder> to write the estimated trajectories (TUM format).

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "dypho/tracking/rgbd_odometry.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

struct StampedPath {
  double t_s = 0;
  std::string path;
};

struct GtPose {
  double t_s = 0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};

bool fileExists(const std::string& path) { return std::ifstream(path).good(); }

/// Lines "timestamp rest..." of a TUM text file, comments skipped.
std::vector<std::vector<std::string>> readTable(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::vector<std::string> row;
    std::string tok;
    while (ss >> tok) row.push_back(tok);
    if (!row.empty()) rows.push_back(row);
  }
  return rows;
}

std::vector<StampedPath> readList(const std::string& path) {
  std::vector<StampedPath> out;
  for (const auto& row : readTable(path)) {
    if (row.size() >= 2) out.push_back({std::stod(row[0]), row[1]});
  }
  return out;
}

std::vector<GtPose> readGroundTruth(const std::string& path) {
  std::vector<GtPose> out;
  for (const auto& r : readTable(path)) {
    if (r.size() < 8) continue;
    GtPose g;
    g.t_s = std::stod(r[0]);
    g.p = Eigen::Vector3d(std::stod(r[1]), std::stod(r[2]), std::stod(r[3]));
    g.q = Eigen::Quaterniond(std::stod(r[7]), std::stod(r[4]), std::stod(r[5]), std::stod(r[6]));
    g.q.normalize();
    out.push_back(g);
  }
  return out;
}

/// Ground-truth position at t by linear interpolation between the bracketing samples (TUM gt is
/// 100 Hz, Bonn ~30 Hz); false when t is outside the gt or the bracketing gap exceeds 0.1 s.
bool interpolateGt(const std::vector<GtPose>& gt, double t, Eigen::Vector3d* p) {
  const auto it = std::lower_bound(gt.begin(), gt.end(), t, [](const GtPose& g, double v) { return g.t_s < v; });
  if (it == gt.begin() || it == gt.end()) return false;
  const GtPose& b = *it;
  const GtPose& a = *(it - 1);
  if (b.t_s - a.t_s > 0.1) return false;
  const double w = (t - a.t_s) / (b.t_s - a.t_s);
  *p = (1 - w) * a.p + w * b.p;
  return true;
}

/// ATE RMSE [m] after a rigid (no scale) Umeyama alignment of estimate onto ground truth.
double ateRmse(const std::vector<Eigen::Vector3d>& est, const std::vector<Eigen::Vector3d>& gt) {
  Eigen::Matrix3Xd A(3, est.size()), B(3, gt.size());
  for (size_t i = 0; i < est.size(); ++i) {
    A.col(static_cast<Eigen::Index>(i)) = est[i];
    B.col(static_cast<Eigen::Index>(i)) = gt[i];
  }
  const Eigen::Matrix4d T = Eigen::umeyama(A, B, false);
  const Eigen::Matrix3Xd aligned = (T.topLeftCorner<3, 3>() * A).colwise() + T.topRightCorner<3, 1>();
  return std::sqrt((aligned - B).colwise().squaredNorm().mean());
}

struct RunStats {
  double ate_m = 0;
  double median_ms = 0;
  int frames = 0;
  int ok = 0;
  int lost = 0;
  int keyframes = 0;
  int evaluated = 0;
};

/// Runs the odometry over a TUM-layout folder and evaluates against `gt` (positions).
RunStats runSequence(const std::string& dir, const CameraIntrinsics& camera, const std::vector<GtPose>& gt,
                     const std::string& name) {
  const std::vector<StampedPath> rgb = readList(dir + "/rgb.txt");
  const std::vector<StampedPath> depth = readList(dir + "/depth.txt");
  RgbdOdometry odometry{TrackingOptions()};
  RunStats stats;
  std::vector<double> times_ms;
  std::vector<Eigen::Vector3d> est, ref;
  std::ofstream traj;
  if (const char* out_dir = std::getenv("DYPHO_TRACKING_TRAJ_DIR")) {
    traj.open(std::string(out_dir) + "/" + name + "_estimate.txt");
  }
  for (const StampedPath& c : rgb) {
    // Nearest depth within 0.02 s (TUM associate rule).
    const StampedPath* best = nullptr;
    for (const StampedPath& d : depth) {
      if (best == nullptr || std::abs(d.t_s - c.t_s) < std::abs(best->t_s - c.t_s)) best = &d;
    }
    if (best == nullptr || std::abs(best->t_s - c.t_s) > 0.02) continue;
    RgbdFrame frame;
    frame.stamp_ns = secondsToTimestamp(c.t_s);
    frame.bgr = cv::imread(dir + "/" + c.path, cv::IMREAD_COLOR);
    const cv::Mat raw = cv::imread(dir + "/" + best->path, cv::IMREAD_UNCHANGED);
    if (frame.bgr.empty() || raw.empty()) {
      ADD_FAILURE() << "cannot read " << c.path << " / " << best->path;
      continue;
    }
    raw.convertTo(frame.depth_m, CV_32F, 1.0 / 5000.0);
    frame.camera = camera;
    const TrackingResult r = odometry.track(frame, cv::Mat());
    ++stats.frames;
    times_ms.push_back(r.times.total);
    EXPECT_TRUE(r.T_world_camera.matrix().allFinite());
    EXPECT_EQ(r.is_keyframe, r.keyframe != nullptr);
    if (r.state == TrackingState::kOk) ++stats.ok;
    if (r.state == TrackingState::kLost) {
      ++stats.lost;
      std::cout << "[" << name << "] frame " << stats.frames - 1 << " LOST: " << r.message << "\n";
    }
    if (r.is_keyframe) ++stats.keyframes;
    if (std::getenv("DYPHO_TRACKING_VERBOSE") != nullptr) {
      std::cout << "[" << name << "] " << stats.frames - 1 << " " << toString(r.state) << " kf=" << r.is_keyframe
                << " feat=" << r.num_features << " matches=" << r.num_matches << " inliers=" << r.num_inliers
                << " t=" << r.times.total << " (f " << r.times.features << " m " << r.times.matching << " p "
                << r.times.pnp << " r " << r.times.refine << ") " << r.message << "\n";
    }
    if (r.state != TrackingState::kOk) continue;
    Eigen::Vector3d p_gt;
    if (!interpolateGt(gt, c.t_s, &p_gt)) continue;
    est.push_back(r.T_world_camera.translation());
    ref.push_back(p_gt);
    if (traj.is_open()) {
      const Eigen::Quaterniond q(r.T_world_camera.rotation());
      const Eigen::Vector3d& p = r.T_world_camera.translation();
      traj << std::fixed << std::setprecision(6) << c.t_s << " " << p.x() << " " << p.y() << " " << p.z() << " "
           << q.x() << " " << q.y() << " " << q.z() << " " << q.w() << "\n";
    }
  }
  stats.evaluated = static_cast<int>(est.size());
  if (est.size() >= 3) stats.ate_m = ateRmse(est, ref);
  if (!times_ms.empty()) {
    std::nth_element(times_ms.begin(), times_ms.begin() + times_ms.size() / 2, times_ms.end());
    stats.median_ms = times_ms[times_ms.size() / 2];
  }
  std::cout << "[" << name << "] frames " << stats.frames << ", OK " << stats.ok << ", LOST " << stats.lost
            << ", keyframes " << stats.keyframes << ", evaluated " << stats.evaluated << ", ATE RMSE "
            << stats.ate_m * 100.0 << " cm, median " << stats.median_ms << " ms/frame" << std::endl;
  return stats;
}

std::string dataDir(const std::string& name) { return std::string(DYPHO_SHARED_DIR) + "/data/" + name; }

TEST(RgbdOdometryRealData, TumFr1RpyAccuracy) {
  const std::string dir = dataDir("tum_fr1_rpy_first150");
  if (!fileExists(dir + "/rgb.txt")) {
    std::cout << "SKIP: " << dir << " not found (set -DDYPHO_SHARED_DIR=... to the shared folder)\n";
    GTEST_SKIP() << dir << " not found";
  }
  CameraIntrinsics cam;  // TUM fr1 RGB calibration (SOURCE.txt)
  cam.fx = 517.306408;
  cam.fy = 516.469215;
  cam.cx = 318.643040;
  cam.cy = 255.313989;
  cam.width = 640;
  cam.height = 480;
  cam.distortion = {{0.262383, -0.953104, -0.005358, 0.002628, 1.163314}};
  const RunStats s = runSequence(dir, cam, readGroundTruth(dir + "/groundtruth.txt"), "tum_fr1_rpy");
  EXPECT_EQ(s.frames, 150);
  // Static scene: every frame must be tracked (measured: 150 of 150).
  EXPECT_EQ(s.evaluated, 150);
  // Measured 3.71 cm with the local map + local BA defaults (2.53 cm with the earlier
  // frame-to-keyframe tracker; OpenCV 4.6, Ceres 2.1, Debian bookworm x86-64). The result depends
  // on which frames become keyframes: neighbouring settings (keyframe_rotation_deg 6..15,
  // keyframe_max_frame_rotation_deg 1.25..1.75, local BA on/off) gave 2.2-4.9 cm, so a different
  // floating-point path (CPU, library build) may move it inside that band. The bound is therefore
  // the 5 cm ceiling of the task, about 1.4x the measured value; a broken Jacobian, undistortion or outlier
  // rejection gives 8-60 cm here.
  EXPECT_LT(s.ate_m, 0.05);
}

TEST(RgbdOdometryRealData, BonnCrowdRough) {
  const std::string dir = dataDir("rgbd_bonn_crowd_frames200to399");
  if (!fileExists(dir + "/rgb.txt")) {
    std::cout << "SKIP: " << dir << " not found\n";
    GTEST_SKIP() << dir << " not found";
  }
  CameraIntrinsics cam;  // Bonn calibration (SOURCE.txt), no distortion
  cam.fx = 542.822841;
  cam.fy = 542.576870;
  cam.cx = 315.593520;
  cam.cy = 237.756098;
  cam.width = 640;
  cam.height = 480;
  std::vector<GtPose> gt = readGroundTruth(dir + "/groundtruth.txt");
  const RunStats raw = runSequence(dir, cam, gt, "bonn_crowd_rawgt");
  // Corrected gt (SOURCE.txt): T_cam = T_ros * T_gt * T_ros * T_m.
  Eigen::Matrix4d T_ros, T_m;
  T_ros << -1, 0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1;
  T_m << 1.0157, 0.1828, -0.2389, 0.0113, 0.0009, -0.8431, -0.6413, -0.0098, -0.3009, 0.6147, -0.8085, 0.0111, 0, 0, 0,
      1;
  for (GtPose& g : gt) {
    Eigen::Matrix4d T_gt = Eigen::Matrix4d::Identity();
    T_gt.topLeftCorner<3, 3>() = g.q.toRotationMatrix();
    T_gt.topRightCorner<3, 1>() = g.p;
    g.p = (T_ros * T_gt * T_ros * T_m).topRightCorner<3, 1>();
  }
  const RunStats corrected = runSequence(dir, cam, gt, "bonn_crowd_correctedgt");
  // No dynamic mask is given here, so people walking through the view (from frame ~35 on) pull
  // the pose: this is a robustness check, not an accuracy target. Measured: 200/200 frames tracked,
  // ATE 18.5 cm with the local map, local BA and one loop closure (~30 cm with the earlier
  // frame-to-keyframe tracker) against both the raw and the corrected ground truth. Bounds: no lost frames
  // allowed beyond 5 %, and ATE < 60 cm (2x measured) catches a collapse of the outlier handling.
  EXPECT_GE(corrected.evaluated, 190);
  EXPECT_LT(corrected.ate_m, 0.60);
  EXPECT_LT(raw.ate_m, 0.60);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
