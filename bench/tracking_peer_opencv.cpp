/// Peer for the tracking benchmark: OpenCV 4.6 opencv_contrib `cv::rgbd::RgbdOdometry` with its
/// default parameters, frame to frame, on a TUM-layout folder read with dypho_tools TumDataset.
/// Writes a TUM trajectory (camera in the first frame) and prints the median time per frame.
///
/// Usage: tracking_peer_opencv --dataset DIR --out TRAJ.txt [--camera NAME_OR_YAML]
/// Evaluate with: dypho_evaluate --estimate TRAJ.txt --groundtruth DIR/groundtruth.txt
///                [--bonn-correction]
/// The peer gets the images as loaded (no undistortion: RgbdOdometry has no distortion model).
/// A frame where compute() fails keeps the last pose (zero motion), as the odometry API offers
/// nothing better; the count of failures is printed.

#include <algorithm>
#include <chrono>
#include <iostream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd.hpp>

#include "dypho/tools/camera_config.h"
#include "dypho/common/trajectory_io.h"
#include "dypho/tools/tum_dataset.h"
#include "help_flag.h"

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: tracking_peer_opencv --dataset DIR --out TRAJ.txt [--camera NAME_OR_YAML]\n"
    "OpenCV's cv::rgbd::RgbdOdometry (default parameters, frame to frame) on a TUM-layout folder:\n"
    "writes a TUM trajectory and prints the median time per frame. Evaluate with dypho_evaluate.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  std::string dataset, out, camera_name;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--dataset")
      dataset = argv[i + 1];
    else if (key == "--out")
      out = argv[i + 1];
    else if (key == "--camera")
      camera_name = argv[i + 1];
    else {
      std::cerr << "unknown argument " << key << "\n";
      return 2;
    }
  }
  if (dataset.empty() || out.empty()) {
    std::cerr << "usage: tracking_peer_opencv --dataset DIR --out TRAJ.txt [--camera NAME]\n";
    return 2;
  }
  try {
    namespace dt = dypho::tools;
    const std::string config_dir = dt::defaultConfigDir();
    if (camera_name.empty()) {
      const auto detected = dt::detectCameraName(dataset);
      if (!detected) throw std::runtime_error("cannot detect the camera of " + dataset + "; pass --camera");
      camera_name = *detected;
    }
    const dt::CameraConfig camera = dt::loadCameraConfig(dt::resolveCameraConfig(camera_name, config_dir));
    const dt::TumDataset data = dt::TumDataset::open(dataset, camera);
    const cv::Mat K = (cv::Mat_<float>(3, 3) << camera.camera.fx, 0, camera.camera.cx, 0, camera.camera.fy,
                       camera.camera.cy, 0, 0, 1);
    cv::rgbd::RgbdOdometry odometry(K);  // default parameters
    std::vector<dypho::StampedPose> trajectory;
    std::vector<double> ms;
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
    cv::Mat prev_gray, prev_depth;
    int failures = 0;
    for (std::size_t i = 0; i < data.size(); ++i) {
      const dypho::RgbdFrame frame = data.load(i);
      cv::Mat gray;
      cv::cvtColor(frame.bgr, gray, cv::COLOR_BGR2GRAY);
      cv::Mat depth = frame.depth_m.clone();
      cv::patchNaNs(depth, 0.0);
      const auto t0 = std::chrono::steady_clock::now();
      if (!prev_gray.empty()) {
        cv::Mat Rt;
        bool ok = false;
        try {
          ok = odometry.compute(prev_gray, prev_depth, cv::Mat(), gray, depth, cv::Mat(), Rt);
        } catch (const cv::Exception&) {
          ok = false;
        }
        if (ok && !Rt.empty()) {
          Eigen::Matrix4d M;
          cv::cv2eigen(Rt, M);  // p_cur = Rt * p_prev
          Eigen::Isometry3d T_cur_prev(M);
          if (T_cur_prev.matrix().allFinite()) T_world_camera = T_world_camera * T_cur_prev.inverse();
        } else {
          ++failures;
        }
      }
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      prev_gray = gray;
      prev_depth = depth;
      trajectory.push_back({dypho::timestampToSeconds(frame.stamp_ns), T_world_camera});
    }
    dypho::writeTumTrajectory(out, trajectory);
    std::sort(ms.begin(), ms.end());
    std::cout << "opencv_rgbd_odometry frames " << trajectory.size() << " failures " << failures << " median_ms "
              << (ms.empty() ? 0.0 : ms[ms.size() / 2]) << " trajectory " << out << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
