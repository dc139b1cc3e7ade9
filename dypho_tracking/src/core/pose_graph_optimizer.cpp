#include "dypho/tracking/pose_graph_optimizer.h"

#include <cmath>
#include <vector>

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include "dypho/tracking/reprojection_error.h"

namespace dypho {
namespace tracking {
namespace {

using Vec4 = Eigen::Vector4d;  // quaternion [x, y, z, w]
using Mat4 = Eigen::Matrix4d;

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// p (x) q == leftMatrix(p) * q.
Mat4 leftMatrix(const Vec4& p) {
  Mat4 L;
  const Eigen::Vector3d v = p.head<3>();
  L.topLeftCorner<3, 3>() = p.w() * Eigen::Matrix3d::Identity() + skew(v);
  L.topRightCorner<3, 1>() = v;
  L.bottomLeftCorner<1, 3>() = -v.transpose();
  L(3, 3) = p.w();
  return L;
}

/// p (x) q == rightMatrix(q) * p.
Mat4 rightMatrix(const Vec4& q) {
  Mat4 R;
  const Eigen::Vector3d v = q.head<3>();
  R.topLeftCorner<3, 3>() = q.w() * Eigen::Matrix3d::Identity() - skew(v);
  R.topRightCorner<3, 1>() = v;
  R.bottomLeftCorner<1, 3>() = -v.transpose();
  R(3, 3) = q.w();
  return R;
}

Vec4 conj(const Vec4& q) { return Vec4(-q.x(), -q.y(), -q.z(), q.w()); }

Vec4 fromEigen(const Eigen::Quaterniond& q) { return Vec4(q.x(), q.y(), q.z(), q.w()); }

}  // namespace

PoseGraphError::PoseGraphError(const Eigen::Isometry3d& T_a_b, double sigma_rot_rad, double sigma_trans_m)
    : q_ab_inv_(Eigen::Quaterniond(T_a_b.rotation()).normalized().conjugate()),
      t_ab_(T_a_b.translation()),
      w_rot_(1.0 / sigma_rot_rad),
      w_trans_(1.0 / sigma_trans_m) {}

bool PoseGraphError::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Vec4 q_a(parameters[0][0], parameters[0][1], parameters[0][2], parameters[0][3]);
  const Eigen::Vector3d t_a(parameters[1][0], parameters[1][1], parameters[1][2]);
  const Vec4 q_b(parameters[2][0], parameters[2][1], parameters[2][2], parameters[2][3]);
  const Eigen::Vector3d t_b(parameters[3][0], parameters[3][1], parameters[3][2]);
  const Vec4 m = fromEigen(q_ab_inv_);
  const Vec4 q_a_conj = conj(q_a);
  const Vec4 m_qa = leftMatrix(m) * q_a_conj;  // q_ab^-1 (x) q_a^-1
  const Vec4 q_err = leftMatrix(m_qa) * q_b;
  const Eigen::Vector3d d = t_b - t_a;
  const Eigen::Vector3d r_t = ReprojectionError::rotate(q_a_conj.data(), d) - t_ab_;
  Eigen::Map<Eigen::Matrix<double, 6, 1>> r(residuals);
  r.head<3>() = 2.0 * w_rot_ * q_err.head<3>();
  r.tail<3>() = w_trans_ * r_t;
  if (jacobians == nullptr) return true;
  const Mat4 C = Eigen::Vector4d(-1, -1, -1, 1).asDiagonal();
  // R_a^T as the linear map of the rotation formula on conj(q_a).
  const Eigen::Vector3d v = q_a_conj.head<3>();
  const Eigen::Matrix3d Rt = Eigen::Matrix3d::Identity() + 2.0 * q_a_conj.w() * skew(v) + 2.0 * skew(v) * skew(v);
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 6, 4, Eigen::RowMajor>> J(jacobians[0]);
    const Mat4 dq = leftMatrix(m) * rightMatrix(q_b) * C;
    J.topRows<3>() = 2.0 * w_rot_ * dq.topRows<3>();
    J.bottomRows<3>() = w_trans_ * quaternionRotationJacobian(q_a_conj.data(), d) * C;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 6, 3, Eigen::RowMajor>> J(jacobians[1]);
    J.topRows<3>().setZero();
    J.bottomRows<3>() = -w_trans_ * Rt;
  }
  if (jacobians[2] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 6, 4, Eigen::RowMajor>> J(jacobians[2]);
    J.topRows<3>() = 2.0 * w_rot_ * leftMatrix(m_qa).topRows<3>();
    J.bottomRows<3>().setZero();
  }
  if (jacobians[3] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 6, 3, Eigen::RowMajor>> J(jacobians[3]);
    J.topRows<3>().setZero();
    J.bottomRows<3>() = w_trans_ * Rt;
  }
  return true;
}

PoseGraphOptimizer::PoseGraphOptimizer(const TrackingOptions& options) : options_(options) { options_.validate(); }

PoseGraphResult PoseGraphOptimizer::optimize(const std::map<std::int64_t, Eigen::Isometry3d>& T_world_keyframe,
                                             const std::vector<PoseGraphEdge>& edges, std::int64_t fixed_id) const {
  PoseGraphResult result;
  result.T_world_keyframe = T_world_keyframe;
  struct Node {
    Eigen::Quaterniond q;
    Eigen::Vector3d t;
  };
  std::map<std::int64_t, Node> nodes;
  for (const auto& kv : T_world_keyframe) {
    if (!kv.second.matrix().allFinite()) {
      result.message = "keyframe " + std::to_string(kv.first) + " has a non-finite pose";
      return result;
    }
    nodes[kv.first] = {Eigen::Quaterniond(kv.second.rotation()).normalized(), kv.second.translation()};
  }
  ceres::Problem problem;
  const double sigma_rot = options_.pose_graph_sigma_rot_deg * M_PI / 180.0;
  int used = 0;
  for (const PoseGraphEdge& e : edges) {
    auto a = nodes.find(e.from), b = nodes.find(e.to);
    if (a == nodes.end() || b == nodes.end() || e.from == e.to || !(e.weight > 0)) continue;
    const double s = 1.0 / std::sqrt(e.weight);
    problem.AddResidualBlock(new PoseGraphError(e.T_from_to, sigma_rot * s, options_.pose_graph_sigma_trans_m * s),
                             nullptr, a->second.q.coeffs().data(), a->second.t.data(), b->second.q.coeffs().data(),
                             b->second.t.data());
    ++used;
  }
  if (used == 0) {
    result.message = "no edge between known keyframes";
    return result;
  }
  for (auto& kv : nodes) {
    if (!problem.HasParameterBlock(kv.second.q.coeffs().data())) continue;
    problem.SetManifold(kv.second.q.coeffs().data(), new ceres::EigenQuaternionManifold());
    if (kv.first == fixed_id) {
      problem.SetParameterBlockConstant(kv.second.q.coeffs().data());
      problem.SetParameterBlockConstant(kv.second.t.data());
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = options_.pose_graph_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  if (!summary.IsSolutionUsable()) {
    result.message = "Ceres failed: " + summary.message;
    return result;
  }
  for (auto& kv : nodes) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = kv.second.q.normalized().toRotationMatrix();
    T.translation() = kv.second.t;
    if (!T.matrix().allFinite()) {
      result.message = "non-finite pose after optimisation";
      result.T_world_keyframe = T_world_keyframe;
      return result;
    }
    result.T_world_keyframe[kv.first] = T;
  }
  result.success = true;
  return result;
}

}  // namespace tracking
}  // namespace dypho
