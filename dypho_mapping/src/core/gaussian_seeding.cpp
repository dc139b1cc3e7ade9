/// GaussianMapper: keyframe validation, undistortion, storage and seeding of new Gaussians.
#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "gaussian_trainer.h"

namespace dypho::mapping {
namespace {

float logit(double p) { return static_cast<float>(std::log(p / (1.0 - p))); }

}  // namespace

bool isRigidPose(const Eigen::Isometry3d& T) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() <= 1e-3 && std::abs(R.determinant() - 1.0) <= 1e-3;
}

std::string checkKeyframe(const Keyframe& kf) {
  if (!kf.T_world_camera.matrix().allFinite()) return "pose is not finite (NaN/inf)";
  if (!isRigidPose(kf.T_world_camera)) return "pose rotation is not a rotation matrix";
  const CameraIntrinsics& cam = kf.frame.camera;
  if (!cam.valid()) return "invalid camera intrinsics (fx, fy, width, height must be > 0)";
  if (kf.frame.bgr.empty() || kf.frame.bgr.type() != CV_8UC3) return "colour image empty or not CV_8UC3 BGR";
  if (kf.frame.depth_m.empty()) return "depth image is empty";
  if (kf.frame.depth_m.type() != CV_32FC1) return "depth image is not CV_32FC1 metres";
  if (kf.frame.bgr.cols != cam.width || kf.frame.bgr.rows != cam.height || kf.frame.depth_m.size() != kf.frame.bgr.size()) {
    return "image sizes differ from each other or from the camera intrinsics";
  }
  if (!kf.mask.empty() && (kf.mask.type() != CV_8UC1 || kf.mask.size() != kf.frame.bgr.size())) {
    return "mask must be empty or CV_8UC1 of the image size";
  }
  return "";
}

const Undistorter& GaussianTrainer::undistorter(const CameraIntrinsics& camera) {
  for (const auto& u : undistorters)
    if (sameCamera(u.camera, camera)) return u;
  Undistorter u;
  u.camera = camera;
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  cv::Mat D(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) D.at<double>(i) = camera.distortion[i];
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, cv::Size(camera.width, camera.height), CV_16SC2, u.map1, u.map2);
  if (undistorters.size() >= 4) undistorters.erase(undistorters.begin());
  undistorters.push_back(std::move(u));
  return undistorters.back();
}

AddKeyframeResult GaussianTrainer::integrate(const Keyframe& kf) {
  AddKeyframeResult result;
  syncToHost();  // seeding renders and extends the current map
  const CameraIntrinsics& cam = kf.frame.camera;
  // 1. Undistort onto the pinhole with the same intrinsics.
  cv::Mat bgr = kf.frame.bgr, depth = kf.frame.depth_m, mask = kf.mask;
  std::vector<cv::Point2f> kp_px;
  for (const auto& k : kf.keypoints) kp_px.emplace_back(k.u_px, k.v_px);
  if (cam.distorted()) {
    const Undistorter& u = undistorter(cam);
    cv::remap(kf.frame.bgr, bgr, u.map1, u.map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    cv::remap(kf.frame.depth_m, depth, u.map1, u.map2, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
    // Pixels outside the undistorted image are excluded like dynamic ones (mask 255).
    const cv::Mat mask_in = kf.mask.empty() ? cv::Mat::zeros(kf.frame.bgr.size(), CV_8UC1) : kf.mask;
    cv::remap(mask_in, mask, u.map1, u.map2, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 255);
    if (!kp_px.empty()) {
      const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
      cv::Mat D(1, 5, CV_64F);
      for (int i = 0; i < 5; ++i) D.at<double>(i) = cam.distortion[i];
      cv::undistortPoints(std::vector<cv::Point2f>(kp_px), kp_px, K, D, cv::noArray(), K);
    }
  }
  // 2. Valid depth: finite and within range; dynamic pixels excluded everywhere.
  cv::Mat depth_valid = depth.clone();
  const float dmin = static_cast<float>(options.valid_min_depth_m), dmax = static_cast<float>(options.valid_max_depth_m);
  std::size_t usable = 0;
  for (int v = 0; v < depth_valid.rows; ++v) {
    float* d = depth_valid.ptr<float>(v);
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(v);
    for (int x = 0; x < depth_valid.cols; ++x) {
      if (!(d[x] >= dmin && d[x] <= dmax)) d[x] = 0.f;
      if (d[x] > 0.f && (!m || m[x] == 0)) ++usable;
    }
  }
  if (usable == 0) {
    result.message = "keyframe " + std::to_string(kf.id) + " has no static pixel with valid depth in [" +
                     std::to_string(options.valid_min_depth_m) + ", " + std::to_string(options.valid_max_depth_m) + "] m; skipped";
    return result;
  }
  // 3. Training-resolution copy.
  TrainingKeyframe t;
  t.id = kf.id;
  t.T_world_camera = kf.T_world_camera;
  const int ds = options.train_downsample;
  t.camera = cam;
  t.camera.distortion = {0, 0, 0, 0, 0};
  t.camera.width = cam.width / ds;
  t.camera.height = cam.height / ds;
  t.camera.fx = cam.fx / ds;
  t.camera.fy = cam.fy / ds;
  t.camera.cx = (cam.cx + 0.5) / ds - 0.5;
  t.camera.cy = (cam.cy + 0.5) / ds - 0.5;
  const cv::Size train_size(t.camera.width, t.camera.height);
  cv::Mat dyn = mask.empty() ? cv::Mat::zeros(bgr.size(), CV_8UC1) : mask;
  if (ds == 1) {
    t.bgr = bgr.clone();
    t.depth_m = depth_valid.clone();
    t.static_mask = (dyn == 0);
  } else {
    cv::resize(bgr, t.bgr, train_size, 0, 0, cv::INTER_AREA);
    cv::resize(depth_valid, t.depth_m, train_size, 0, 0, cv::INTER_NEAREST);
    cv::Mat dyn_small;
    cv::resize(dyn, dyn_small, train_size, 0, 0, cv::INTER_AREA);  // any dynamic sub-pixel -> dynamic
    t.static_mask = (dyn_small == 0);
  }
  // 4. Seeds: keypoints and samples around them, then unexplained static pixels.
  const float init_logit = logit(options.initial_opacity);
  auto add = [&](int u, int v, float sigma_px, float depth_m = -1.f) -> bool {
    if (u < 0 || v < 0 || u >= depth_valid.cols || v >= depth_valid.rows) return true;
    const float d = depth_m >= 0.f ? depth_m : depth_valid.at<float>(v, u);
    if (!(d > 0.f) || dyn.at<std::uint8_t>(v, u) != 0) return true;
    GaussianInit g;
    const Eigen::Vector3d pc((u - cam.cx) / cam.fx * d, (v - cam.cy) / cam.fy * d, d);
    g.position_w = (kf.T_world_camera * pc).cast<float>();
    const float s = std::log(sigma_px * d / static_cast<float>(cam.fx));
    g.log_scale = {s, s, s};
    g.opacity_logit = init_logit;
    const cv::Vec3b c = bgr.at<cv::Vec3b>(v, u);
    g.sh = {rgbToShDc(c[2] / 255.f), rgbToShDc(c[1] / 255.f), rgbToShDc(c[0] / 255.f)};
    g.anchor_keyframe_id = kf.id;
    if (map.add(g) < 0) {
      result.capacity_reached = true;
      return false;
    }
    ++result.new_gaussians;
    return true;
  };
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  const float r = static_cast<float>(options.feature_sample_radius_px);
  bool room = true;
  for (const auto& p : kp_px) {
    if (!room) break;
    const int u = static_cast<int>(std::lround(p.x)), v = static_cast<int>(std::lround(p.y));
    room = add(u, v, std::max(1.f, r / 3.f));
    for (int s = 0; s < options.feature_samples && room; ++s) {
      room = add(static_cast<int>(std::lround(p.x + r * unit(rng))), static_cast<int>(std::lround(p.y + r * unit(rng))),
                 std::max(1.f, r / 3.f));
    }
  }
  if (room) {
    renderPinhole(kf.T_world_camera, t.camera, render_raster, seed_out);
    const int stride = options.coverage_stride_px;
    const std::size_t tw = static_cast<std::size_t>(t.camera.width);
    // Coverage grid: measured depth at each node (0 = none); static nodes without a measurement
    // take the farthest depth of their nearest measured static neighbours (dilation on the grid).
    const int gw = (depth_valid.cols - stride / 2 + stride - 1) / stride;
    const int gh = (depth_valid.rows - stride / 2 + stride - 1) / stride;
    cv::Mat grid(std::max(gh, 0), std::max(gw, 0), CV_32FC1, cv::Scalar(0.f));
    cv::Mat filled(grid.size(), CV_8UC1, cv::Scalar(0));
    for (int gv = 0; gv < gh; ++gv)
      for (int gu = 0; gu < gw; ++gu) {
        const int u = stride / 2 + gu * stride, v = stride / 2 + gv * stride;
        if (dyn.at<std::uint8_t>(v, u) == 0) grid.at<float>(gv, gu) = depth_valid.at<float>(v, u);
      }
    if (options.coverage_fill_invalid_depth) {
      cv::Mat next = grid.clone();
      for (int pass = 0, changed = 1; changed && pass < std::max(gw, gh); ++pass) {
        changed = 0;
        for (int gv = 0; gv < gh; ++gv)
          for (int gu = 0; gu < gw; ++gu) {
            if (grid.at<float>(gv, gu) > 0.f) continue;
            float best = 0.f;
            for (int dv = -1; dv <= 1; ++dv)
              for (int du = -1; du <= 1; ++du) {
                const int nu = gu + du, nv = gv + dv;
                if (nu >= 0 && nv >= 0 && nu < gw && nv < gh) best = std::max(best, grid.at<float>(nv, nu));
              }
            if (best > 0.f) {
              next.at<float>(gv, gu) = best;
              filled.at<std::uint8_t>(gv, gu) = 1;
              changed = 1;
            }
          }
        next.copyTo(grid);
      }
    }
    for (int gv = 0; gv < gh && room; ++gv) {
      for (int gu = 0; gu < gw && room; ++gu) {
        const int u = stride / 2 + gu * stride, v = stride / 2 + gv * stride;
        const int tu = std::min(t.camera.width - 1, u / ds), tv = std::min(t.camera.height - 1, v / ds);
        const float a = seed_out.alpha[tv * tw + tu];
        const float d = grid.at<float>(gv, gu);
        if (!(d > 0.f)) continue;
        const float dr = a > 1e-3f ? seed_out.depth[tv * tw + tu] / a : 0.f;
        // A node without a measurement is unexplained only when nothing is rendered there.
        const bool unexplained = a < options.coverage_alpha_threshold ||
                                 (!filled.at<std::uint8_t>(gv, gu) && std::abs(dr - d) > options.coverage_depth_error_ratio * d);
        if (unexplained) room = add(u, v, 0.5f * stride, d);
      }
    }
  }
  if (result.capacity_reached) {
    ++capacity_hits;
    result.message = "max_gaussians (" + std::to_string(options.max_gaussians) + ") reached: keyframe " +
                     std::to_string(kf.id) + " seeded partially";
  }
  // 5. Store; drop the images of the oldest keyframes beyond max_stored_keyframes.
  keyframes.push_back(std::move(t));
  std::size_t with_images = 0;
  for (auto it = keyframes.rbegin(); it != keyframes.rend(); ++it) {
    if (!it->hasImages()) continue;
    if (++with_images > static_cast<std::size_t>(options.max_stored_keyframes)) {
      if (cuda) cuda->dropTarget(it->id);
      it->bgr.release();
      it->depth_m.release();
      it->static_mask.release();
    }
  }
  adam.resize(map);
  grad_accum.resize(map.size(), 0.f);
  grad_count.resize(map.size(), 0);
  hostChanged();
  result.added = true;
  return result;
}

}  // namespace dypho::mapping
