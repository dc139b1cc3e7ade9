#include "dypho/tracking/local_bundle_adjuster.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <unordered_map>
#include <vector>

#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include "dypho/tracking/reprojection_error.h"

namespace dypho {
namespace tracking {
namespace {

/// Pose of one keyframe as Ceres parameters (T_camera_world).
struct PoseBlock {
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
  bool fixed = false;
};

struct Observation {
  std::int64_t keyframe_id;
  std::int64_t point_id;
  int feature_index;
  ceres::ResidualBlockId block;
  ceres::ResidualBlockId depth_block;  ///< nullptr without depth term
};

}  // namespace

LocalBundleAdjuster::LocalBundleAdjuster(const TrackingOptions& options) : options_(options) {
  options_.validate();
}

LocalBaResult LocalBundleAdjuster::adjust(TrackerMap* map, std::int64_t newest_keyframe_id,
                                          const Pinhole& pinhole) const {
  LocalBaResult result;
  if (options_.local_ba_keyframes <= 0) {
    result.message = "local BA disabled (local_ba_keyframes = 0)";
    return result;
  }
  if (map == nullptr || map->keyframe(newest_keyframe_id) == nullptr) {
    result.message = "unknown keyframe";
    return result;
  }
  // Window and points.
  std::map<std::int64_t, PoseBlock> poses;
  std::vector<std::int64_t> free_ids{newest_keyframe_id};
  for (std::int64_t id : map->covisibleKeyframes(newest_keyframe_id, options_.local_ba_keyframes - 1)) {
    free_ids.push_back(id);
  }
  if (free_ids.size() < 2) {
    result.message = "no covisible keyframe yet";
    return result;
  }
  std::set<std::int64_t> point_ids;
  for (std::int64_t k : free_ids) {
    for (std::int64_t id : map->keyframe(k)->map_point_ids) {
      if (map->point(id) != nullptr) point_ids.insert(id);
    }
  }
  const std::set<std::int64_t> free_set(free_ids.begin(), free_ids.end());
  std::map<std::int64_t, int> fixed_weight;  // keyframes outside the window seeing the points
  for (std::int64_t id : point_ids) {
    for (const auto& obs : map->point(id)->observations) {
      if (free_set.count(obs.first) == 0) ++fixed_weight[obs.first];
    }
  }
  std::vector<std::pair<int, std::int64_t>> fixed_sorted;
  for (const auto& kv : fixed_weight) fixed_sorted.emplace_back(kv.second, kv.first);
  std::sort(fixed_sorted.rbegin(), fixed_sorted.rend());
  if (static_cast<int>(fixed_sorted.size()) > options_.local_ba_max_fixed_keyframes) {
    fixed_sorted.resize(static_cast<size_t>(options_.local_ba_max_fixed_keyframes));
  }
  const auto addPose = [&](std::int64_t id, bool fixed) {
    const Eigen::Isometry3d T_cw = map->keyframe(id)->T_world_camera.inverse();
    poses[id] = {Eigen::Quaterniond(T_cw.rotation()).normalized(), T_cw.translation(), fixed};
  };
  for (std::int64_t id : free_ids) addPose(id, false);
  for (const auto& f : fixed_sorted) addPose(f.second, true);
  if (fixed_sorted.empty()) poses.begin()->second.fixed = true;  // oldest of the window: gauge

  std::unordered_map<std::int64_t, Eigen::Vector3d> points;
  for (std::int64_t id : point_ids) points[id] = map->point(id)->p_world_m;

  ceres::Problem::Options po;
  po.enable_fast_removal = true;
  ceres::Problem problem(po);
  ceres::LossFunction* loss = new ceres::HuberLoss(options_.huber_px);
  std::vector<Observation> observations;
  std::vector<double> level_sigma(static_cast<size_t>(options_.num_levels));
  for (int l = 0; l < options_.num_levels; ++l) {
    level_sigma[static_cast<size_t>(l)] = std::pow(options_.scale_factor, l);
  }
  const double bf = options_.local_ba_depth_baseline_m * pinhole.fx;
  for (auto& kv : poses) {
    const MapKeyframe* kf = map->keyframe(kv.first);
    PoseBlock& pose = kv.second;
    for (size_t i = 0; i < kf->map_point_ids.size(); ++i) {
      auto p = points.find(kf->map_point_ids[i]);
      if (p == points.end()) continue;
      const int level = std::clamp(kf->features.keypoints[i].octave, 0, options_.num_levels - 1);
      auto* cost = new BaReprojectionError(kf->features.uv_undistorted_px[i],
                                           level_sigma[static_cast<size_t>(level)], pinhole);
      // Skip observations behind the camera at the start (would make Evaluate fail).
      const Eigen::Vector3d p_c = pose.q * p->second + pose.t;
      if (!(p_c.z() > 1e-3)) {
        delete cost;
        continue;
      }
      const auto block = problem.AddResidualBlock(cost, loss, pose.q.coeffs().data(),
                                                  pose.t.data(), p->second.data());
      ceres::ResidualBlockId depth_block = nullptr;
      const double depth = kf->features.depth_m[i];
      if (bf > 0 && depth > 0) {
        depth_block = problem.AddResidualBlock(
            new BaDepthError(depth, bf, level_sigma[static_cast<size_t>(level)]), loss,
            pose.q.coeffs().data(), pose.t.data(), p->second.data());
      }
      observations.push_back({kv.first, p->first, static_cast<int>(i), block, depth_block});
    }
  }
  if (observations.empty()) {
    result.message = "no observations";
    return result;
  }
  for (auto& kv : poses) {
    if (!problem.HasParameterBlock(kv.second.q.coeffs().data())) continue;
    problem.SetManifold(kv.second.q.coeffs().data(), new ceres::EigenQuaternionManifold());
    if (kv.second.fixed) {
      problem.SetParameterBlockConstant(kv.second.q.coeffs().data());
      problem.SetParameterBlockConstant(kv.second.t.data());
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.max_num_iterations = options_.local_ba_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    result.message = "Ceres failed: " + summary.message;
    return result;
  }
  // Remove chi2 outliers, then a second round.
  std::vector<bool> outlier(observations.size(), false);
  for (size_t k = 0; k < observations.size(); ++k) {
    double r[2], r_depth = 0;
    double cost = 0;
    bool ok = problem.EvaluateResidualBlock(observations[k].block, false, &cost, r, nullptr);
    if (ok && observations[k].depth_block != nullptr) {
      ok = problem.EvaluateResidualBlock(observations[k].depth_block, false, &cost, &r_depth,
                                         nullptr);
    }
    const double chi2 = r[0] * r[0] + r[1] * r[1] + r_depth * r_depth;
    const double threshold = observations[k].depth_block != nullptr ? options_.chi2_threshold_depth
                                                                    : options_.chi2_threshold;
    if (!ok || chi2 > threshold) {
      outlier[k] = true;
      problem.RemoveResidualBlock(observations[k].block);
      if (observations[k].depth_block != nullptr) {
        problem.RemoveResidualBlock(observations[k].depth_block);
      }
      ++result.removed_observations;
    }
  }
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    result.message = "Ceres failed in round 2: " + summary.message;
    return result;
  }
  // Write back.
  for (const auto& kv : poses) {
    if (kv.second.fixed) continue;
    Eigen::Isometry3d T_cw = Eigen::Isometry3d::Identity();
    T_cw.linear() = kv.second.q.normalized().toRotationMatrix();
    T_cw.translation() = kv.second.t;
    if (!T_cw.matrix().allFinite()) continue;
    map->mutableKeyframe(kv.first)->T_world_camera = T_cw.inverse();
    ++result.optimized_keyframes;
  }
  for (const auto& kv : points) {
    if (kv.second.allFinite()) map->mutablePoint(kv.first)->p_world_m = kv.second;
  }
  for (size_t k = 0; k < observations.size(); ++k) {
    if (!outlier[k]) continue;
    MapPoint* p = map->mutablePoint(observations[k].point_id);
    MapKeyframe* kf = map->mutableKeyframe(observations[k].keyframe_id);
    if (p == nullptr || kf == nullptr || p->observations.size() <= 1) continue;  // keep sole obs
    p->observations.erase(observations[k].keyframe_id);
    kf->map_point_ids[static_cast<size_t>(observations[k].feature_index)] = -1;
  }
  result.fixed_keyframes = static_cast<int>(poses.size()) - result.optimized_keyframes;
  result.points = static_cast<int>(points.size());
  result.observations = static_cast<int>(observations.size());
  result.ran = true;
  return result;
}

}  // namespace tracking
}  // namespace dypho
