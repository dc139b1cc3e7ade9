/// StaticSceneCheck: dense photometric agreement and refinement against the reference keyframe.
#include "dypho/tracking/static_scene_check.h"

#include "dense_image.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <opencv2/imgproc.hpp>

#include "dypho/common/rounding.h"

namespace dypho {
namespace tracking {
namespace {

using dense::bilinear;
using dense::median;
using dense::reduce;
using dense::scaledPinhole;
using dense::validDepth;

}  // namespace

StaticSceneCheck::StaticSceneCheck(const StaticSceneCheckSettings& settings) : settings_(settings) {}

void StaticSceneCheck::clear() {
  reference_id_ = -1;
  for (Level& level : levels_) level = Level();
}

void StaticSceneCheck::sampleLevel(const cv::Mat& grey, const cv::Mat& depth_m, const cv::Mat& mask,
                                   Level* level) const {
  cv::Mat gx, gy;
  cv::Sobel(grey, gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(grey, gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
  struct Candidate {
    int x, y;
  };
  std::vector<Candidate> candidates;
  const float min_sq = static_cast<float>(settings_.min_gradient * settings_.min_gradient);
  for (int y = 2; y < grey.rows - 2; ++y) {
    const float* ax = gx.ptr<float>(y);
    const float* ay = gy.ptr<float>(y);
    const float* d = depth_m.ptr<float>(y);
    const uchar* m = mask.ptr<uchar>(y);
    for (int x = 2; x < grey.cols - 2; ++x) {
      if (m[x] == 0 && validDepth(d[x]) && ax[x] * ax[x] + ay[x] * ay[x] > min_sq) candidates.push_back({x, y});
    }
  }
  const std::size_t stride =
      std::max<std::size_t>(1, (candidates.size() + static_cast<std::size_t>(settings_.max_samples) - 1) /
                                   static_cast<std::size_t>(settings_.max_samples));
  level->p_reference_m.clear();
  level->grey_reference.clear();
  for (std::size_t i = 0; i < candidates.size(); i += stride) {
    const Candidate& c = candidates[i];
    const double z = depth_m.at<float>(c.y, c.x);
    level->p_reference_m.push_back(level->pinhole.backProject(Eigen::Vector2d(c.x, c.y), z));
    level->grey_reference.push_back(grey.at<float>(c.y, c.x));
  }
}

bool StaticSceneCheck::setReference(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask) {
  clear();
  if (frame.bgr.empty() || frame.depth_m.empty() || !frame.camera.valid()) return false;
  for (int l = 0; l < 2; ++l) {
    const double scale = settings_.scale / (l == 0 ? 1.0 : 2.0);
    cv::Mat grey, depth, mask_small;
    reduce(frame, mask, scale, &undistort_[l], &grey, &depth, &mask_small);
    levels_[l].pinhole = scaledPinhole(frame.camera, static_cast<double>(grey.cols) / frame.bgr.cols,
                                       static_cast<double>(grey.rows) / frame.bgr.rows);
    sampleLevel(grey, depth, mask_small, &levels_[l]);
  }
  if (levels_[0].p_reference_m.size() < 50) {
    clear();
    return false;
  }
  reference_id_ = keyframe_id;
  return true;
}

void StaticSceneCheck::setCurrent(const RgbdFrame& frame, const cv::Mat& mask) {
  for (int l = 0; l < 2; ++l) {
    Level& level = levels_[l];
    const double scale = settings_.scale / (l == 0 ? 1.0 : 2.0);
    reduce(frame, mask, scale, &undistort_[l], &level.grey, &level.depth_m, &level.mask);
    cv::Sobel(level.grey, level.grad_x, CV_32F, 1, 0, 3, 1.0 / 8.0);
    cv::Sobel(level.grey, level.grad_y, CV_32F, 0, 1, 3, 1.0 / 8.0);
  }
}

StaticAgreement StaticSceneCheck::score(const Eigen::Isometry3d& T_current_reference) const {
  StaticAgreement out;
  const Level& level = levels_[0];
  if (reference_id_ < 0 || level.grey.empty()) return out;
  std::vector<double> residuals;
  std::vector<char> depth_ok;
  residuals.reserve(level.p_reference_m.size());
  for (std::size_t i = 0; i < level.p_reference_m.size(); ++i) {
    const Eigen::Vector3d q = T_current_reference * level.p_reference_m[i];
    if (q.z() < 0.05) continue;
    const Eigen::Vector2d uv = level.pinhole.project(q);
    if (!(uv.x() >= 0.0 && uv.y() >= 0.0 && uv.x() < level.grey.cols - 1 && uv.y() < level.grey.rows - 1)) continue;
    const int u = roundHalfAway(uv.x()), v = roundHalfAway(uv.y());
    const float z = level.depth_m.at<float>(v, u);
    if (level.mask.at<uchar>(v, u) != 0 || !validDepth(z)) continue;
    const double tolerance_m = std::max(settings_.depth_tolerance_m, 0.015 * q.z() * q.z());
    residuals.push_back(bilinear(level.grey, uv.x(), uv.y()) - level.grey_reference[i]);
    depth_ok.push_back(std::abs(z - q.z()) < tolerance_m);
  }
  out.checked = static_cast<int>(residuals.size());
  std::vector<double> sorted = residuals;
  const double offset = median(&sorted);  // exposure change between the two images
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    out.agreeing += depth_ok[i] && std::abs(residuals[i] - offset) < settings_.photometric_tolerance;
  }
  return out;
}

void StaticSceneCheck::refineLevel(const Level& level, Eigen::Isometry3d* T_current_reference) const {
  const int n = static_cast<int>(level.p_reference_m.size());
  std::vector<double> r(static_cast<std::size_t>(n));
  std::vector<Eigen::Matrix<double, 1, 6>> J(static_cast<std::size_t>(n));
  std::vector<char> used(static_cast<std::size_t>(n));
  std::vector<double> used_r;
  used_r.reserve(static_cast<std::size_t>(n));
  for (int it = 0; it < settings_.iterations; ++it) {
    used_r.clear();
    for (int i = 0; i < n; ++i) {
      used[static_cast<std::size_t>(i)] = 0;
      const Eigen::Vector3d q = *T_current_reference * level.p_reference_m[static_cast<std::size_t>(i)];
      if (q.z() < 0.05) continue;
      const Eigen::Vector2d uv = level.pinhole.project(q);
      if (!(uv.x() >= 0.0 && uv.y() >= 0.0 && uv.x() < level.grey.cols - 1 && uv.y() < level.grey.rows - 1)) continue;
      const int u = roundHalfAway(uv.x()), v = roundHalfAway(uv.y());
      if (level.mask.at<uchar>(v, u) != 0) continue;
      const float z = level.depth_m.at<float>(v, u);
      // Occluded by something nearer (a person in front): not this sample's surface.
      if (validDepth(z) && z < q.z() - std::max(settings_.depth_tolerance_m, 0.015 * q.z() * q.z())) continue;
      const dense::BilinearPoint at(uv.x(), uv.y());
      const double gx = at.sample(level.grad_x), gy = at.sample(level.grad_y);
      const double iz = 1.0 / q.z();
      const double fx = level.pinhole.fx, fy = level.pinhole.fy;
      // d r / d(v, w) for q' = q + v + w x q (left perturbation of T_current_reference).
      const Eigen::Vector3d dr_dq(gx * fx * iz, gy * fy * iz, -(gx * fx * q.x() + gy * fy * q.y()) * iz * iz);
      Eigen::Matrix<double, 1, 6> j;
      j.head<3>() = dr_dq.transpose();
      j.tail<3>() = q.cross(dr_dq).transpose();
      J[static_cast<std::size_t>(i)] = j;
      r[static_cast<std::size_t>(i)] = at.sample(level.grey) - level.grey_reference[static_cast<std::size_t>(i)];
      used[static_cast<std::size_t>(i)] = 1;
      used_r.push_back(r[static_cast<std::size_t>(i)]);
    }
    if (used_r.size() < 30) return;
    const double offset = median(&used_r);
    for (double& x : used_r) x = std::abs(x - offset);
    const double sigma = std::max(2.0, 1.4826 * median(&used_r));
    const double huber = 1.345 * sigma, cut = 4.0 * sigma;
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    for (int i = 0; i < n; ++i) {
      if (!used[static_cast<std::size_t>(i)]) continue;
      const double e = r[static_cast<std::size_t>(i)] - offset;
      const double a = std::abs(e);
      if (a > cut) continue;  // occlusion, moving object, specular: no pull at all
      const double w = a <= huber ? 1.0 : huber / a;
      const auto& j = J[static_cast<std::size_t>(i)];
      H.noalias() += w * j.transpose() * j;
      g.noalias() += w * j.transpose() * e;
    }
    H.diagonal() *= 1.0 + 1e-4;
    const Eigen::Matrix<double, 6, 1> delta = -H.ldlt().solve(g);
    if (!delta.allFinite()) return;
    *T_current_reference = dense::leftStep(delta) * *T_current_reference;
    if (delta.head<3>().norm() < 1e-5 && delta.tail<3>().norm() < 1e-5) return;
  }
}

Eigen::Isometry3d StaticSceneCheck::refine(const Eigen::Isometry3d& T_current_reference_init) const {
  Eigen::Isometry3d T = T_current_reference_init;
  if (reference_id_ < 0 || levels_[0].grey.empty()) return T;
  refineLevel(levels_[1], &T);
  refineLevel(levels_[0], &T);
  return T;
}

}  // namespace tracking
}  // namespace dypho
