#pragma once
/// \file pose_graph_optimizer.h
/// SE(3) pose-graph optimisation of keyframe poses (Ceres) for loop closure.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/sized_cost_function.h>

#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// Relative-pose residual between two keyframe poses T_world_a, T_world_b with the measurement
/// T_a_b (6 x 1): r = W [2 vec(q_ab^-1 (x) q_a^-1 (x) q_b); R_a^T (t_b - t_a) - t_ab], with
/// W = diag(1/sigma_rot_rad x3, 1/sigma_trans_m x3). Parameters: block 0 q_a [x, y, z, w]
/// (EigenQuaternionManifold), block 1 t_a [m], block 2 q_b, block 3 t_b (all of T_world_*).
/// Analytic Jacobians of exactly this expression (quaternion products are bilinear; R_a^T is
/// applied with the rotation formula of ReprojectionError::rotate on the conjugate q_a).
class PoseGraphError final : public ceres::SizedCostFunction<6, 4, 3, 4, 3> {
 public:
  /// T_a_b: measured relative pose; sigma_rot_rad, sigma_trans_m: standard deviations (> 0).
  PoseGraphError(const Eigen::Isometry3d& T_a_b, double sigma_rot_rad, double sigma_trans_m);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Quaterniond q_ab_inv_;
  Eigen::Vector3d t_ab_;
  double w_rot_;
  double w_trans_;
};

/// One relative-pose constraint T_from_to (= T_world_from^-1 T_world_to).
struct PoseGraphEdge {
  std::int64_t from = -1;                                       ///< keyframe id a
  std::int64_t to = -1;                                         ///< keyframe id b
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();  ///< measured relative pose
  double weight = 1.0;  ///< multiplies both information weights (loop edges may be trusted more)
};

/// Result of PoseGraphOptimizer::optimize.
struct PoseGraphResult {
  bool success = false;                                        ///< Ceres produced a usable solution
  std::map<std::int64_t, Eigen::Isometry3d> T_world_keyframe;  ///< optimised poses (all nodes)
  double initial_cost = 0;                                     ///< Ceres cost before [-]
  double final_cost = 0;                                       ///< Ceres cost after [-]
  std::string message;                                         ///< why it failed; empty on success
};

/// Optimises all keyframe poses of a graph of relative-pose edges (odometry, covisibility, loop)
/// with Levenberg-Marquardt (sparse normal Cholesky), keeping `fixed_id` constant (gauge).
class PoseGraphOptimizer {
 public:
  /// Uses pose_graph_iterations, pose_graph_sigma_rot_deg, pose_graph_sigma_trans_m.
  explicit PoseGraphOptimizer(const TrackingOptions& options);

  /// Never throws on data; edges to unknown ids are ignored.
  PoseGraphResult optimize(const std::map<std::int64_t, Eigen::Isometry3d>& T_world_keyframe,
                           const std::vector<PoseGraphEdge>& edges, std::int64_t fixed_id) const;

 private:
  TrackingOptions options_;
};

}  // namespace tracking
}  // namespace dypho
