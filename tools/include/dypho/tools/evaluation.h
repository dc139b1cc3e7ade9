#pragma once
/// \file evaluation.h
/// Trajectory accuracy: absolute trajectory error (ATE, rigid alignment without scale, as the TUM
/// evaluate_ate.py tool) and relative pose error (RPE over a fixed time delta, as evaluate_rpe.py),
/// plus the Bonn RGB-D Dynamic ground-truth correction.

#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "dypho/common/trajectory_io.h"

namespace dypho::tools {

/// How the estimate is aligned onto the ground truth before the ATE is taken.
enum class AteAlignment {
  kRigid,      ///< rotation + translation (SE(3)): the ATE of the TUM benchmark, the default
  kWithScale,  ///< rotation + translation + one scale (Sim(3)): separates a scale error (e.g. of
               ///< the depth sensor) from the shape of the trajectory
};

/// Absolute trajectory error of an estimate after alignment onto the ground truth.
struct AteResult {
  double rmse_m = 0;          ///< root mean square of the position errors [m]
  double mean_m = 0;          ///< mean position error [m]
  double median_m = 0;        ///< median position error [m]
  double max_m = 0;           ///< largest position error [m]
  double std_m = 0;           ///< population standard deviation of the position errors [m]
  std::size_t num_pairs = 0;  ///< number of (estimate, interpolated ground truth) pairs
  /// Rigid transform applied to the estimate: p_gt ~ T_gt_est * (scale * p_est)
  Eigen::Isometry3d T_gt_est = Eigen::Isometry3d::Identity();
  /// Scale applied to the estimate (1 with AteAlignment::kRigid); above 1: the estimated
  /// trajectory is shorter than the ground truth
  double scale = 1.0;
  std::vector<Eigen::Vector3d> est_aligned_xyz;  ///< aligned estimate positions [m], per pair
  std::vector<Eigen::Vector3d> gt_xyz;           ///< ground-truth positions [m], per pair
  std::vector<double> stamps_s;                  ///< estimate stamps [s], per pair
};

/// Relative pose error over a time delta.
struct RpeResult {
  double trans_rmse_m = 0;    ///< RMS of the relative translation errors [m]
  double rot_rmse_deg = 0;    ///< RMS of the relative rotation error angles [deg]
  double trans_mean_m = 0;    ///< mean relative translation error [m]
  double rot_mean_deg = 0;    ///< mean relative rotation error angle [deg]
  std::size_t num_pairs = 0;  ///< number of (i, j) pose pairs
  double delta_s = 1.0;       ///< time delta between the poses of a pair [s]
};

/// Ground-truth pose at time `t_s` [s] from `groundtruth` sorted by stamp: linear interpolation of
/// the position, slerp of the rotation between the two bracketing samples. An exact stamp match
/// returns that sample. std::nullopt when `t_s` is outside the ground truth or the bracketing
/// samples are more than `max_gap_s` [s] apart (then one of them is also farther than that from t_s).
std::optional<Eigen::Isometry3d> interpolatePose(const std::vector<StampedPose>& groundtruth, double t_s,
                                                 double max_gap_s);

/// Pairs every estimate with the ground truth interpolated at its stamp (interpolatePose), aligns
/// the estimate positions onto the ground truth (default: rigid, rotation + translation, NO
/// scale; umeyamaAlignNoScale; kWithScale adds Umeyama's least-squares scale) and reports the
/// position errors. Inputs need not be sorted. Throws std::runtime_error when fewer than 3 pairs
/// exist (names the stamp ranges).
AteResult computeAte(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     double max_gap_s = 0.1, AteAlignment alignment = AteAlignment::kRigid);

/// RPE over `delta_s` [s]: every estimate pose i with interpolated ground truth is paired with the
/// pose j whose stamp is closest to t_i + delta_s (accepted when within max_gap_s of it);
/// error E = (G_i^-1 G_j)^-1 (P_i^-1 P_j); translational error |t(E)|, rotational error
/// angle(R(E)). No alignment is needed (relative motions). Throws std::runtime_error when no pair
/// exists or delta_s <= 0.
RpeResult computeRpe(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     double delta_s = 1.0, double max_gap_s = 0.1);

/// Least-squares rigid transform (Horn/Umeyama without scale) with dst_i ~ T * src_i.
/// Throws std::runtime_error when sizes differ or fewer than 3 points are given.
Eigen::Isometry3d umeyamaAlignNoScale(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst);

/// Bonn RGB-D Dynamic Dataset axis permutation T_ros (published 4x4).
Eigen::Matrix4d bonnTRos();
/// Bonn marker-to-camera matrix T_m exactly as published. Its 3x3 block is 1.0593 x a rotation
/// (singular values 1.05924 .. 1.05935), so it is not rigid.
Eigen::Matrix4d bonnTmPublished();
/// T_m with its 3x3 block replaced by the nearest rotation (SVD polar factor); translation unchanged.
Eigen::Isometry3d bonnTmRigid();

/// Bonn ground-truth correction (marker body -> camera optical centre), per pose:
/// T_cam = T_ros * T_gt * T_ros * T_m with T_m = bonnTmRigid(). Positions equal those of the
/// published formula exactly (the 3x3 block of T_m does not affect the translation); rotations
/// are the rigid version of it.
std::vector<StampedPose> applyBonnCorrection(const std::vector<StampedPose>& groundtruth);

}  // namespace dypho::tools
