#include "dypho/mask/ego_motion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>

namespace dypho {
namespace mask {

void predictRigidPrevious(const cv::Mat& cur_px, const cv::Mat& depth_m, const CameraIntrinsics& camera,
                          const Eigen::Isometry3d& T_prev_cur, cv::Mat& predicted_prev_px) {
  CV_Assert(cur_px.type() == CV_32FC2 && depth_m.type() == CV_32FC1 && cur_px.size() == depth_m.size() &&
            camera.fx > 0.0 && camera.fy > 0.0);
  predicted_prev_px.create(cur_px.size(), CV_32FC2);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Matrix3d R = T_prev_cur.linear();
  const Eigen::Vector3d t = T_prev_cur.translation();
  const double ifx = 1.0 / camera.fx, ify = 1.0 / camera.fy;
  for (int y = 0; y < cur_px.rows; ++y) {
    const cv::Vec2f* c = cur_px.ptr<cv::Vec2f>(y);
    const float* d = depth_m.ptr<float>(y);
    cv::Vec2f* p = predicted_prev_px.ptr<cv::Vec2f>(y);
    for (int x = 0; x < cur_px.cols; ++x) {
      const float z = d[x];
      if (!(z > 0.f) || !std::isfinite(c[x][0])) {  // also rejects NaN depth
        p[x] = cv::Vec2f(nan, nan);
        continue;
      }
      const Eigen::Vector3d X_cur(z * (c[x][0] - camera.cx) * ifx, z * (c[x][1] - camera.cy) * ify, z);
      const Eigen::Vector3d X_prev = R * X_cur + t;
      if (X_prev.z() <= 0.01) {
        p[x] = cv::Vec2f(nan, nan);
        continue;
      }
      p[x] = cv::Vec2f(static_cast<float>(camera.fx * X_prev.x() / X_prev.z() + camera.cx),
                       static_cast<float>(camera.fy * X_prev.y() / X_prev.z() + camera.cy));
    }
  }
}

namespace {

/// A current cell's back-projected point and where the flow says it was in the previous image.
struct RigidSample {
  Eigen::Vector3d X_cur;    ///< [m], current camera
  Eigen::Vector2d prev_px;  ///< measured previous position [full-res undistorted px]
};

std::vector<RigidSample> collectSamples(const cv::Mat& cur_px, const cv::Mat& depth_m, const cv::Mat& measured_prev_px,
                                        const cv::Mat& usable, const CameraIntrinsics& camera, int stride) {
  CV_Assert(cur_px.type() == CV_32FC2 && depth_m.type() == CV_32FC1 && measured_prev_px.type() == CV_32FC2 &&
            cur_px.size() == depth_m.size() && cur_px.size() == measured_prev_px.size() &&
            (usable.empty() || (usable.type() == CV_8UC1 && usable.size() == cur_px.size())) && camera.fx > 0.0 &&
            camera.fy > 0.0 && stride >= 1);
  std::vector<RigidSample> samples;
  samples.reserve(static_cast<std::size_t>(cur_px.total() / (stride * stride) + 1));
  for (int y = stride / 2; y < cur_px.rows; y += stride) {
    const cv::Vec2f* c = cur_px.ptr<cv::Vec2f>(y);
    const float* d = depth_m.ptr<float>(y);
    const cv::Vec2f* m = measured_prev_px.ptr<cv::Vec2f>(y);
    const uchar* u = usable.empty() ? nullptr : usable.ptr<uchar>(y);
    for (int x = stride / 2; x < cur_px.cols; x += stride) {
      const float z = d[x];
      if ((u != nullptr && u[x] == 0) || !(z > 0.f) || !std::isfinite(z) || !std::isfinite(c[x][0]) ||
          !std::isfinite(m[x][0]) || !std::isfinite(m[x][1])) {
        continue;
      }
      samples.push_back(
          {Eigen::Vector3d(z * (c[x][0] - camera.cx) / camera.fx, z * (c[x][1] - camera.cy) / camera.fy, z),
           Eigen::Vector2d(m[x][0], m[x][1])});
    }
  }
  return samples;
}

}  // namespace

/// On the last kCutoffIterations iterations, samples further than kCutoff * final_scale_px from
/// the prediction are left out.
constexpr int kCutoffIterations = 3;
constexpr double kCutoff = 3.0;

RigidFit fitRigidMotion(const cv::Mat& cur_px, const cv::Mat& depth_m, const cv::Mat& measured_prev_px,
                        const cv::Mat& usable, const CameraIntrinsics& camera, const Eigen::Isometry3d& T_start,
                        const RigidFitSettings& settings) {
  RigidFit fit;
  const std::vector<RigidSample> samples =
      collectSamples(cur_px, depth_m, measured_prev_px, usable, camera, settings.sample_stride);
  fit.samples = static_cast<int>(samples.size());
  if (fit.samples < settings.min_samples) return fit;
  const Eigen::Matrix3d R_start = T_start.linear();
  const Eigen::Vector3d t_start = T_start.translation();
  Eigen::Matrix3d R = R_start;
  Eigen::Vector3d t = t_start;
  // Prior information per unit of translation and rotation: a deviation that moves the image by
  // prior_image_motion_px (at the median depth) costs as much as every sample 1 px off.
  std::vector<double> depths(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) depths[i] = samples[i].X_cur.z();
  std::nth_element(depths.begin(), depths.begin() + static_cast<std::ptrdiff_t>(depths.size() / 2), depths.end());
  const double focal_px = 0.5 * (camera.fx + camera.fy);
  const double per_px2 = fit.samples / (settings.prior_image_motion_px * settings.prior_image_motion_px);
  const double prior_t = per_px2 * (focal_px / depths[depths.size() / 2]) * (focal_px / depths[depths.size() / 2]);
  const double prior_r = per_px2 * focal_px * focal_px;
  double scale_px = std::max(settings.initial_scale_px, settings.final_scale_px);
  for (int iteration = 0; iteration < settings.iterations; ++iteration) {
    // Left perturbation T <- exp(xi) T, xi = (v, w): Y = R X + t moves by v + w x Y.
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    const double inv_scale2 = 1.0 / (scale_px * scale_px);
    const bool last_iterations = iteration >= settings.iterations - kCutoffIterations;
    for (const RigidSample& s : samples) {
      const Eigen::Vector3d Y = R * s.X_cur + t;
      if (Y.z() <= 0.01) continue;
      const double iz = 1.0 / Y.z();
      const Eigen::Vector2d r(camera.fx * Y.x() * iz + camera.cx - s.prev_px.x(),
                              camera.fy * Y.y() * iz + camera.cy - s.prev_px.y());
      // Cauchy weights, and on the last iterations none beyond kCutoff scales: a mover's few
      // pixels of residual keep a Cauchy weight that would bias the pose.
      const double r2 = r.squaredNorm();
      if (last_iterations && r2 > kCutoff * kCutoff * scale_px * scale_px) continue;
      const double w = 1.0 / (1.0 + r2 * inv_scale2);
      Eigen::Matrix<double, 2, 3> J_proj;
      J_proj << camera.fx * iz, 0.0, -camera.fx * Y.x() * iz * iz, 0.0, camera.fy * iz, -camera.fy * Y.y() * iz * iz;
      Eigen::Matrix<double, 3, 6> J_point;
      J_point << Eigen::Matrix3d::Identity(),
          -(Eigen::Matrix3d() << 0.0, -Y.z(), Y.y(), Y.z(), 0.0, -Y.x(), -Y.y(), Y.x(), 0.0).finished();
      const Eigen::Matrix<double, 2, 6> J = J_proj * J_point;
      H.noalias() += w * J.transpose() * J;
      g.noalias() += w * J.transpose() * r;
    }
    // The prior on the start pose: about 1 / prior_image_motion_px^2 of the samples' weight where
    // the flow determines the motion (a bias of that share of the correction); it holds the pose
    // where the flow does not (a turn and a sideways move look alike on a distant wall), so that
    // movers cannot drag it there.
    const Eigen::Matrix3d R_dev = R * R_start.transpose();
    Eigen::Matrix<double, 6, 1> deviation;
    deviation.head<3>() = t - R_dev * t_start;
    const Eigen::AngleAxisd turn(R_dev);
    deviation.tail<3>() = turn.axis() * turn.angle();
    Eigen::Matrix<double, 6, 1> prior_information;
    prior_information.head<3>().setConstant(prior_t);
    prior_information.tail<3>().setConstant(prior_r);
    H.diagonal() += prior_information;
    g += prior_information.cwiseProduct(deviation);
    H.diagonal() *= 1.0 + 1e-6;  // Levenberg-Marquardt's damping, small: the problem is well posed
    const Eigen::Matrix<double, 6, 1> xi = H.ldlt().solve(-g);
    if (!xi.allFinite()) return fit;
    const double angle = xi.tail<3>().norm();
    const Eigen::Matrix3d dR =
        angle > 0.0 ? Eigen::AngleAxisd(angle, xi.tail<3>() / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    R = dR * R;
    t = dR * t + xi.head<3>();
    scale_px = std::max(settings.final_scale_px, 0.5 * scale_px);
  }
  fit.T_prev_cur.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  fit.T_prev_cur.translation() = t;
  fit.ok = fit.T_prev_cur.matrix().allFinite();
  return fit;
}

int countRigidInliers(const cv::Mat& cur_px, const cv::Mat& depth_m, const cv::Mat& measured_prev_px,
                      const cv::Mat& usable, const CameraIntrinsics& camera, const Eigen::Isometry3d& T_prev_cur,
                      double threshold_px, int sample_stride) {
  const std::vector<RigidSample> samples =
      collectSamples(cur_px, depth_m, measured_prev_px, usable, camera, sample_stride);
  const double threshold2 = threshold_px * threshold_px;
  int inliers = 0;
  for (const RigidSample& s : samples) {
    const Eigen::Vector3d Y = T_prev_cur * s.X_cur;
    if (Y.z() <= 0.01) continue;
    const Eigen::Vector2d p(camera.fx * Y.x() / Y.z() + camera.cx, camera.fy * Y.y() / Y.z() + camera.cy);
    inliers += (p - s.prev_px).squaredNorm() < threshold2;
  }
  return inliers;
}

}  // namespace mask
}  // namespace dypho
