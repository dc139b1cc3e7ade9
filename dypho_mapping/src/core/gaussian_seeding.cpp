/// GaussianMapper: keyframe validation, undistortion, storage and seeding of new Gaussians.
#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "gaussian_trainer.h"

namespace dypho::mapping {
namespace {

float logit(double p) { return static_cast<float>(std::log(p / (1.0 - p))); }

/// A keyframe's images and keypoints on the undistorted pinhole with the same intrinsics.
struct PinholeImages {
  cv::Mat bgr, depth_m, mask;  ///< mask empty when the keyframe has none (and no distortion)
  std::vector<cv::Point2f> keypoints_px;
};

/// Step 1: undistorts the keyframe onto the pinhole with the same intrinsics (`u`: its maps, null
/// when the camera has no distortion; the images are then shared, not copied).
PinholeImages undistortKeyframe(const Keyframe& kf, const Undistorter* u) {
  const CameraIntrinsics& cam = kf.frame.camera;
  PinholeImages out{kf.frame.bgr, kf.frame.depth_m, kf.mask, {}};
  std::vector<cv::Point2f>& kp_px = out.keypoints_px;
  for (const auto& k : kf.keypoints) kp_px.emplace_back(k.u_px, k.v_px);
  if (u) {
    cv::remap(kf.frame.bgr, out.bgr, u->map1, u->map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    cv::remap(kf.frame.depth_m, out.depth_m, u->map1, u->map2, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
    // Pixels outside the undistorted image are excluded like dynamic ones (mask 255).
    const cv::Mat mask_in = kf.mask.empty() ? cv::Mat::zeros(kf.frame.bgr.size(), CV_8UC1) : kf.mask;
    cv::remap(mask_in, out.mask, u->map1, u->map2, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 255);
    if (!kp_px.empty()) {
      const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
      cv::Mat D(1, 5, CV_64F);
      for (int i = 0; i < 5; ++i) D.at<double>(i) = cam.distortion[i];
      cv::undistortPoints(std::vector<cv::Point2f>(kp_px), kp_px, K, D, cv::noArray(), K);
    }
  }
  return out;
}

/// Step 2: a copy of `depth_m` with every value outside [min_m, max_m] (NaN included) set to 0;
/// `usable` counts its static pixels (mask 0, or no mask) with a valid depth.
cv::Mat rangeCheckedDepth(const cv::Mat& depth_m, const cv::Mat& mask, float min_m, float max_m, std::size_t& usable) {
  cv::Mat depth_valid = depth_m.clone();
  usable = 0;
  for (int v = 0; v < depth_valid.rows; ++v) {
    float* d = depth_valid.ptr<float>(v);
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(v);
    for (int x = 0; x < depth_valid.cols; ++x) {
      if (!(d[x] >= min_m && d[x] <= max_m)) d[x] = 0.f;
      if (d[x] > 0.f && (!m || m[x] == 0)) ++usable;
    }
  }
  return depth_valid;
}

/// The pinhole `cam` (distortion dropped) at 1/ds of its resolution, pixel centres kept in place.
CameraIntrinsics downsampledPinhole(const CameraIntrinsics& cam, int ds) {
  CameraIntrinsics out = cam;
  out.distortion = {0, 0, 0, 0, 0};
  out.width = cam.width / ds;
  out.height = cam.height / ds;
  out.fx = cam.fx / ds;
  out.fy = cam.fy / ds;
  out.cx = (cam.cx + 0.5) / ds - 0.5;
  out.cy = (cam.cy + 0.5) / ds - 0.5;
  return out;
}

/// Step 3: the training-resolution copy of a keyframe (`dyn`: CV_8UC1, non-zero = dynamic).
TrainingKeyframe trainingKeyframe(const Keyframe& kf, int ds, const cv::Mat& bgr, const cv::Mat& depth_valid,
                                  const cv::Mat& dyn) {
  TrainingKeyframe t;
  t.id = kf.id;
  t.T_world_camera = kf.T_world_camera;
  t.T_world_camera_tracked = kf.T_world_camera;
  t.camera = downsampledPinhole(kf.frame.camera, ds);
  const cv::Size train_size(t.camera.width, t.camera.height);
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
  return t;
}

/// Step 4's seeding of one Gaussian at a static pixel of the keyframe (full resolution, pinhole).
struct Seeder {
  const Keyframe& kf;
  const cv::Mat& bgr;          ///< CV_8UC3 undistorted colour
  const cv::Mat& depth_valid;  ///< CV_32FC1 [m], 0 = invalid
  const cv::Mat& dyn;          ///< CV_8UC1, non-zero = dynamic
  float init_logit;            ///< opacity logit of new Gaussians
  GaussianMap& map;
  AddKeyframeResult& result;

  /// Adds a Gaussian of screen size sigma_px at pixel (u, v) with depth `depth_m` (< 0: the
  /// measured one); pixels outside the image, dynamic or without depth are skipped. Returns
  /// false once the map is full.
  bool add(int u, int v, float sigma_px, float depth_m = -1.f) {
    const CameraIntrinsics& cam = kf.frame.camera;
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
  }
};

/// Seeds at each keypoint and at `feature_samples` random pixels around it; returns false once
/// the map is full.
bool seedAtKeypoints(Seeder& seeder, const std::vector<cv::Point2f>& kp_px, const GaussianMapperOptions& options,
                     std::mt19937& rng) {
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  const float r = static_cast<float>(options.feature_sample_radius_px);
  bool room = true;
  for (const auto& p : kp_px) {
    if (!room) break;
    const int u = static_cast<int>(std::lround(p.x)), v = static_cast<int>(std::lround(p.y));
    room = seeder.add(u, v, std::max(1.f, r / 3.f));
    for (int s = 0; s < options.feature_samples && room; ++s) {
      room = seeder.add(static_cast<int>(std::lround(p.x + r * unit(rng))),
                        static_cast<int>(std::lround(p.y + r * unit(rng))), std::max(1.f, r / 3.f));
    }
  }
  return room;
}

/// Coverage grid: one node per stride x stride cell, at full-resolution pixel
/// (stride / 2 + gu stride, stride / 2 + gv stride).
struct CoverageGrid {
  int stride = 1, gw = 0, gh = 0;
  cv::Mat depth_m;  ///< CV_32FC1 [gh, gw]: depth at each node (0 = none)
  cv::Mat filled;   ///< CV_8UC1 [gh, gw]: 1 where the depth was taken from neighbours
};

/// The grid with the measured depth of each static node (0 at dynamic nodes and invalid depth).
CoverageGrid measureCoverageGrid(const cv::Mat& depth_valid, const cv::Mat& dyn, int stride) {
  CoverageGrid g;
  g.stride = stride;
  g.gw = (depth_valid.cols - stride / 2 + stride - 1) / stride;
  g.gh = (depth_valid.rows - stride / 2 + stride - 1) / stride;
  g.depth_m = cv::Mat(std::max(g.gh, 0), std::max(g.gw, 0), CV_32FC1, cv::Scalar(0.f));
  g.filled = cv::Mat(g.depth_m.size(), CV_8UC1, cv::Scalar(0));
  for (int gv = 0; gv < g.gh; ++gv)
    for (int gu = 0; gu < g.gw; ++gu) {
      const int u = stride / 2 + gu * stride, v = stride / 2 + gv * stride;
      if (dyn.at<std::uint8_t>(v, u) == 0) g.depth_m.at<float>(gv, gu) = depth_valid.at<float>(v, u);
    }
  return g;
}

/// Static nodes without a measurement take the farthest depth of their nearest measured static
/// neighbours (dilation on the grid, pass by pass until nothing changes).
void fillCoverageGrid(CoverageGrid& g) {
  cv::Mat& grid = g.depth_m;
  const int gw = g.gw, gh = g.gh;
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
          g.filled.at<std::uint8_t>(gv, gu) = 1;
          changed = 1;
        }
      }
    next.copyTo(grid);
  }
}

/// Seeds at the grid nodes the map does not explain in `rendered` (training resolution, camera
/// `train_camera`, 1/ds of the grid's pixels); returns false once the map is full.
bool seedUnexplainedNodes(Seeder& seeder, const CoverageGrid& g, const RenderResult<float>& rendered,
                          const CameraIntrinsics& train_camera, int ds, const GaussianMapperOptions& options) {
  const int stride = g.stride;
  const std::size_t tw = static_cast<std::size_t>(train_camera.width);
  bool room = true;
  for (int gv = 0; gv < g.gh && room; ++gv) {
    for (int gu = 0; gu < g.gw && room; ++gu) {
      const int u = stride / 2 + gu * stride, v = stride / 2 + gv * stride;
      const int tu = std::min(train_camera.width - 1, u / ds), tv = std::min(train_camera.height - 1, v / ds);
      const float a = rendered.alpha[tv * tw + tu];
      const float d = g.depth_m.at<float>(gv, gu);
      if (!(d > 0.f)) continue;
      const float dr = a > 1e-3f ? rendered.depth[tv * tw + tu] / a : 0.f;
      // A node without a measurement is unexplained only when nothing is rendered there.
      const bool unexplained =
          a < options.coverage_alpha_threshold ||
          (!g.filled.at<std::uint8_t>(gv, gu) && std::abs(dr - d) > options.coverage_depth_error_ratio * d);
      if (unexplained) room = seeder.add(u, v, 0.5f * stride, d);
    }
  }
  return room;
}

/// Step 5: appends `t` to the trainer's keyframes; drops the images (host and device) of the
/// oldest keyframes beyond max_stored_keyframes.
void storeKeyframe(GaussianTrainer& trainer, TrainingKeyframe t) {
  std::vector<TrainingKeyframe>& keyframes = trainer.keyframes;
  keyframes.push_back(std::move(t));
  std::size_t with_images = 0;
  for (auto it = keyframes.rbegin(); it != keyframes.rend(); ++it) {
    if (!it->hasImages()) continue;
    if (++with_images > static_cast<std::size_t>(trainer.options.max_stored_keyframes)) {
      if (trainer.cuda) trainer.cuda->dropTarget(it->id);
      it->bgr.release();
      it->depth_m.release();
      it->static_mask.release();
    }
  }
}

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
  if (kf.frame.bgr.cols != cam.width || kf.frame.bgr.rows != cam.height ||
      kf.frame.depth_m.size() != kf.frame.bgr.size()) {
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
  const PinholeImages img = undistortKeyframe(kf, cam.distorted() ? &undistorter(cam) : nullptr);
  const cv::Mat& bgr = img.bgr;
  const cv::Mat& mask = img.mask;
  // 2. Valid depth: finite and within range; dynamic pixels excluded everywhere.
  const float dmin = static_cast<float>(options.valid_min_depth_m),
              dmax = static_cast<float>(options.valid_max_depth_m);
  std::size_t usable = 0;
  const cv::Mat depth_valid = rangeCheckedDepth(img.depth_m, mask, dmin, dmax, usable);
  if (usable == 0) {
    result.message = "keyframe " + std::to_string(kf.id) + " has no static pixel with valid depth in [" +
                     std::to_string(options.valid_min_depth_m) + ", " + std::to_string(options.valid_max_depth_m) +
                     "] m; skipped";
    return result;
  }
  // 3. Training-resolution copy.
  const int ds = options.train_downsample;
  cv::Mat dyn = mask.empty() ? cv::Mat::zeros(bgr.size(), CV_8UC1) : mask;
  TrainingKeyframe t = trainingKeyframe(kf, ds, bgr, depth_valid, dyn);
  // 4. Seeds: keypoints and samples around them, then unexplained static pixels.
  Seeder seeder{kf, bgr, depth_valid, dyn, logit(options.initial_opacity), map, result};
  if (seedAtKeypoints(seeder, img.keypoints_px, options, rng)) {
    renderPinhole(kf.T_world_camera, t.camera, render_raster, seed_out);
    CoverageGrid grid = measureCoverageGrid(depth_valid, dyn, options.coverage_stride_px);
    if (options.coverage_fill_invalid_depth) fillCoverageGrid(grid);
    seedUnexplainedNodes(seeder, grid, seed_out, t.camera, ds, options);
  }
  if (result.capacity_reached) {
    ++capacity_hits;
    result.message = "max_gaussians (" + std::to_string(options.max_gaussians) + ") reached: keyframe " +
                     std::to_string(kf.id) + " seeded partially";
  }
  // 5. Store; drop the images of the oldest keyframes beyond max_stored_keyframes.
  storeKeyframe(*this, std::move(t));
  adam.resize(map);
  grad_accum.resize(map.size(), 0.f);
  grad_count.resize(map.size(), 0);
  hostChanged();
  result.added = true;
  return result;
}

}  // namespace dypho::mapping
