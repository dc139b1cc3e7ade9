#include "dypho/tools/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/SVD>

namespace dypho::tools {
namespace {

std::vector<StampedPose> sortedByStamp(std::vector<StampedPose> poses) {
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp_s < b.stamp_s; });
  return poses;
}

std::string range(const std::vector<StampedPose>& poses) {
  if (poses.empty()) return "(empty)";
  const auto [lo, hi] = std::minmax_element(
      poses.begin(), poses.end(), [](const StampedPose& a, const StampedPose& b) { return a.stamp_s < b.stamp_s; });
  char buf[128];
  std::snprintf(buf, sizeof(buf), "%zu poses, %.6f .. %.6f s", poses.size(), lo->stamp_s, hi->stamp_s);
  return buf;
}

/// Nearest rotation to `m` (polar factor), det = +1.
Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) s(2, 2) = -1.0;
  return svd.matrixU() * s * svd.matrixV().transpose();
}

double rotationAngleDeg(const Eigen::Matrix3d& r) {
  constexpr double kRadToDeg = 57.29577951308232;  // 180 / pi
  return Eigen::AngleAxisd(nearestRotation(r)).angle() * kRadToDeg;
}

struct PosePair {
  double stamp_s;
  Eigen::Isometry3d T_est;
  Eigen::Isometry3d T_gt;
};

std::vector<PosePair> pairWithGroundTruth(const std::vector<StampedPose>& estimate,
                                          const std::vector<StampedPose>& groundtruth, double max_gap_s) {
  if (!(max_gap_s > 0.0)) throw std::runtime_error("max_gap_s must be > 0 (default 0.1 s)");
  const auto gt = sortedByStamp(groundtruth);
  std::vector<PosePair> pairs;
  for (const auto& e : sortedByStamp(estimate)) {
    if (auto g = interpolatePose(gt, e.stamp_s, max_gap_s)) pairs.push_back({e.stamp_s, e.T_world_camera, *g});
  }
  return pairs;
}

}  // namespace

std::optional<Eigen::Isometry3d> interpolatePose(const std::vector<StampedPose>& groundtruth, double t_s,
                                                 double max_gap_s) {
  auto it = std::lower_bound(groundtruth.begin(), groundtruth.end(), t_s,
                             [](const StampedPose& p, double t) { return p.stamp_s < t; });
  if (it == groundtruth.end()) return std::nullopt;
  if (it->stamp_s == t_s) return it->T_world_camera;
  if (it == groundtruth.begin()) return std::nullopt;
  const StampedPose& b = *it;
  const StampedPose& a = *(it - 1);
  const double gap = b.stamp_s - a.stamp_s;
  if (!(gap <= max_gap_s)) return std::nullopt;
  const double s = (t_s - a.stamp_s) / gap;
  const Eigen::Quaterniond qa(a.T_world_camera.rotation());
  const Eigen::Quaterniond qb(b.T_world_camera.rotation());
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = qa.slerp(s, qb).toRotationMatrix();
  out.translation() = (1.0 - s) * a.T_world_camera.translation() + s * b.T_world_camera.translation();
  return out;
}

Eigen::Isometry3d umeyamaAlignNoScale(const std::vector<Eigen::Vector3d>& src,
                                      const std::vector<Eigen::Vector3d>& dst) {
  if (src.size() != dst.size()) {
    throw std::runtime_error("umeyamaAlignNoScale: " + std::to_string(src.size()) + " source vs " +
                             std::to_string(dst.size()) + " destination points");
  }
  if (src.size() < 3) {
    throw std::runtime_error("umeyamaAlignNoScale: need at least 3 point pairs, got " + std::to_string(src.size()));
  }
  const double n = static_cast<double>(src.size());
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_dst = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    mean_src += src[i];
    mean_dst += dst[i];
  }
  mean_src /= n;
  mean_dst /= n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  // sum (dst - mean) (src - mean)^T
  for (std::size_t i = 0; i < src.size(); ++i) {
    cov += (dst[i] - mean_dst) * (src[i] - mean_src).transpose();
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = nearestRotation(cov);  // maximises trace(R^T cov) over rotations (Umeyama 1991)
  T.translation() = mean_dst - T.linear() * mean_src;
  return T;
}

AteResult computeAte(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     double max_gap_s, AteAlignment alignment) {
  const auto pairs = pairWithGroundTruth(estimate, groundtruth, max_gap_s);
  if (pairs.size() < 3) {
    throw std::runtime_error("ATE needs at least 3 estimate poses with ground truth within " +
                             std::to_string(max_gap_s) + " s, got " + std::to_string(pairs.size()) +
                             " (estimate: " + range(estimate) + "; ground truth: " + range(groundtruth) +
                             "; do the stamps use the same clock?)");
  }
  AteResult r;
  std::vector<Eigen::Vector3d> est_xyz;
  for (const auto& p : pairs) {
    est_xyz.push_back(p.T_est.translation());
    r.gt_xyz.push_back(p.T_gt.translation());
    r.stamps_s.push_back(p.stamp_s);
  }
  r.T_gt_est = umeyamaAlignNoScale(est_xyz, r.gt_xyz);
  if (alignment == AteAlignment::kWithScale) {
    // Umeyama (1991): with the optimal rotation R, s = trace(R^T C) / sum |p_est - mean|^2, C =
    // sum (p_gt - mean_gt)(p_est - mean_est)^T; then t = mean_gt - s R mean_est.
    Eigen::Vector3d mean_est = Eigen::Vector3d::Zero(), mean_gt = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < est_xyz.size(); ++i) {
      mean_est += est_xyz[i];
      mean_gt += r.gt_xyz[i];
    }
    mean_est /= static_cast<double>(est_xyz.size());
    mean_gt /= static_cast<double>(est_xyz.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    double spread = 0.0;
    for (std::size_t i = 0; i < est_xyz.size(); ++i) {
      cov += (r.gt_xyz[i] - mean_gt) * (est_xyz[i] - mean_est).transpose();
      spread += (est_xyz[i] - mean_est).squaredNorm();
    }
    if (!(spread > 0.0)) throw std::runtime_error("ATE with scale: the estimate does not move (all positions equal)");
    r.scale = (r.T_gt_est.linear().transpose() * cov).trace() / spread;
    r.T_gt_est.translation() = mean_gt - r.scale * (r.T_gt_est.linear() * mean_est);
  }
  std::vector<double> err;
  double sum = 0, sum_sq = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    r.est_aligned_xyz.push_back(r.T_gt_est * (r.scale * est_xyz[i]));
    const double e = (r.est_aligned_xyz.back() - r.gt_xyz[i]).norm();
    err.push_back(e);
    sum += e;
    sum_sq += e * e;
    r.max_m = std::max(r.max_m, e);
  }
  const double n = static_cast<double>(err.size());
  r.num_pairs = err.size();
  r.rmse_m = std::sqrt(sum_sq / n);
  r.mean_m = sum / n;
  r.std_m = std::sqrt(std::max(0.0, sum_sq / n - r.mean_m * r.mean_m));
  std::sort(err.begin(), err.end());
  r.median_m = err.size() % 2 == 1 ? err[err.size() / 2] : 0.5 * (err[err.size() / 2 - 1] + err[err.size() / 2]);
  return r;
}

RpeResult computeRpe(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     double delta_s, double max_gap_s) {
  if (!(delta_s > 0.0)) throw std::runtime_error("RPE delta_s must be > 0 (default 1 s)");
  const auto pairs = pairWithGroundTruth(estimate, groundtruth, max_gap_s);
  RpeResult r;
  r.delta_s = delta_s;
  double sum_t = 0, sum_t2 = 0, sum_r = 0, sum_r2 = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const double target = pairs[i].stamp_s + delta_s;
    auto it = std::lower_bound(pairs.begin() + static_cast<long>(i) + 1, pairs.end(), target,
                               [](const PosePair& p, double t) { return p.stamp_s < t; });
    // Closest of the two neighbours of the target time.
    std::size_t j = static_cast<std::size_t>(it - pairs.begin());
    if (it != pairs.begin() + static_cast<long>(i) + 1 &&
        (it == pairs.end() || target - (it - 1)->stamp_s < it->stamp_s - target)) {
      --j;
    }
    if (j >= pairs.size() || j <= i || std::abs(pairs[j].stamp_s - target) > max_gap_s) continue;
    const Eigen::Isometry3d d_gt = pairs[i].T_gt.inverse() * pairs[j].T_gt;
    const Eigen::Isometry3d d_est = pairs[i].T_est.inverse() * pairs[j].T_est;
    const Eigen::Isometry3d e = d_gt.inverse() * d_est;
    const double et = e.translation().norm();
    const double er = rotationAngleDeg(e.linear());
    sum_t += et;
    sum_t2 += et * et;
    sum_r += er;
    sum_r2 += er * er;
    ++r.num_pairs;
  }
  if (r.num_pairs == 0) {
    throw std::runtime_error("RPE over " + std::to_string(delta_s) + " s: no pose pair found (" +
                             std::to_string(pairs.size()) +
                             " estimate poses have ground truth; is the trajectory shorter than "
                             "delta_s? use a smaller --delta)");
  }
  const double n = static_cast<double>(r.num_pairs);
  r.trans_rmse_m = std::sqrt(sum_t2 / n);
  r.rot_rmse_deg = std::sqrt(sum_r2 / n);
  r.trans_mean_m = sum_t / n;
  r.rot_mean_deg = sum_r / n;
  return r;
}

Eigen::Matrix4d bonnTRos() {
  Eigen::Matrix4d m;
  m << -1, 0, 0, 0,  //
      0, 0, 1, 0,    //
      0, 1, 0, 0,    //
      0, 0, 0, 1;
  return m;
}

Eigen::Matrix4d bonnTmPublished() {
  Eigen::Matrix4d m;
  m << 1.0157, 0.1828, -0.2389, 0.0113,   //
      0.0009, -0.8431, -0.6413, -0.0098,  //
      -0.3009, 0.6147, -0.8085, 0.0111,   //
      0, 0, 0, 1;
  return m;
}

Eigen::Isometry3d bonnTmRigid() {
  const Eigen::Matrix4d m = bonnTmPublished();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = nearestRotation(m.topLeftCorner<3, 3>());
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

std::vector<StampedPose> applyBonnCorrection(const std::vector<StampedPose>& groundtruth) {
  Eigen::Isometry3d T_ros = Eigen::Isometry3d::Identity();
  T_ros.matrix() = bonnTRos();
  const Eigen::Isometry3d T_m = bonnTmRigid();
  std::vector<StampedPose> out = groundtruth;
  for (auto& p : out) p.T_world_camera = T_ros * p.T_world_camera * T_ros * T_m;
  return out;
}

}  // namespace dypho::tools
