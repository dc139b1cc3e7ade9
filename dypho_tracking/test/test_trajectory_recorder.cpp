#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/trajectory_recorder.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

Eigen::Isometry3d pose(double x, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, 0.1, 0.0);
  return T;
}

TrackingResult tracked(Timestamp stamp, std::int64_t reference, const Eigen::Isometry3d& T_world_ref,
                       const Eigen::Isometry3d& T_world_camera) {
  TrackingResult r;
  r.stamp_ns = stamp;
  r.state = TrackingState::kOk;
  r.reference_keyframe_id = reference;
  r.T_world_camera = T_world_camera;
  r.T_reference_camera = T_world_ref.inverse() * T_world_camera;
  return r;
}

TEST(TrajectoryRecorder, FramesFollowTheLaterCorrectionOfTheirKeyframe) {
  TrackerMap map{TrackingOptions()};
  MapKeyframe kf0, kf1;
  kf0.id = 0;
  kf0.T_world_camera = pose(0.0, 0.0);
  kf1.id = 1;
  kf1.T_world_camera = pose(1.0, 0.2);
  map.addKeyframe(kf0);
  map.addKeyframe(kf1);

  TrajectoryRecorder recorder;
  const Eigen::Isometry3d frame_a = pose(0.3, 0.05), frame_b = pose(1.2, 0.25);
  recorder.add(tracked(10, 0, kf0.T_world_camera, frame_a));
  TrackingResult lost = tracked(15, 0, kf0.T_world_camera, frame_a);
  lost.state = TrackingState::kLost;  // not tracked: keeps its published pose
  recorder.add(lost);
  recorder.add(tracked(20, 1, kf1.T_world_camera, frame_b));
  ASSERT_EQ(recorder.records().size(), 3u);

  // Before any correction the final poses equal the online ones.
  auto final_poses = recorder.finalPoses(map);
  ASSERT_EQ(final_poses.size(), 3u);
  EXPECT_TRUE(final_poses[0].second.isApprox(frame_a, 1e-12));
  EXPECT_TRUE(final_poses[2].second.isApprox(frame_b, 1e-12));

  // Local BA / a loop closure moves both keyframes: the tracked frames move rigidly with their
  // keyframe, the lost frame keeps what was published.
  const Eigen::Isometry3d correction0 = pose(0.02, 0.01), correction1 = pose(-0.05, -0.02);
  map.applyKeyframePoses({{0, correction0 * kf0.T_world_camera}, {1, correction1 * kf1.T_world_camera}});
  final_poses = recorder.finalPoses(map);
  EXPECT_TRUE(final_poses[0].second.isApprox(correction0 * frame_a, 1e-12));
  EXPECT_TRUE(final_poses[1].second.isApprox(frame_a, 1e-12));
  EXPECT_TRUE(final_poses[2].second.isApprox(correction1 * frame_b, 1e-12));
  EXPECT_EQ(final_poses[2].first, 20);
  // The online poses are what was published.
  EXPECT_TRUE(recorder.onlinePoses()[2].second.isApprox(frame_b, 1e-12));

  // Keyframe 1 removed as redundant: its frames follow the keyframe it was attached to.
  ASSERT_TRUE(map.removeKeyframe(1));
  const Eigen::Isometry3d correction0b = pose(0.01, -0.03);
  const Eigen::Isometry3d T_world_0 = map.keyframe(0)->T_world_camera;
  map.applyKeyframePoses({{0, correction0b * T_world_0}});
  final_poses = recorder.finalPoses(map);
  EXPECT_TRUE(final_poses[2].second.isApprox(correction0b * correction1 * frame_b, 1e-12));

  // After a reset (keyframes gone) the online pose is kept.
  map.clear();
  final_poses = recorder.finalPoses(map);
  EXPECT_TRUE(final_poses[2].second.isApprox(frame_b, 1e-12));
}

using Poses = std::vector<std::pair<Timestamp, Eigen::Isometry3d>>;

/// A hand-held camera's position at 30 Hz frame `k` [m]: 10 cm swings at 0.5 Hz (about 1 m/s^2
/// at the turning points), turning about the vertical.
Eigen::Isometry3d swing(int k) {
  const double t_s = k / 30.0, w = 2.0 * M_PI * 0.5;
  Eigen::Isometry3d T = pose(0.1 * std::sin(w * t_s), 0.3 * t_s);
  T.translation().z() = 0.05 * std::cos(w * t_s);
  return T;
}

Timestamp frameStampNs(int k) { return static_cast<Timestamp>(k) * 33333333; }

double positionErrorRmsM(const Poses& poses, const std::vector<Eigen::Isometry3d>& truth) {
  double sum_sq = 0.0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    sum_sq += (poses[k].second.translation() - truth[k].translation()).squaredNorm();
  }
  return std::sqrt(sum_sq / static_cast<double>(poses.size()));
}

/// `swing` at 30 Hz for `frames` frames with white noise of `sigma_m` per axis on the positions
/// (generator seeded with `seed`); the noise-free poses go to `truth`.
Poses noisySwing(int frames, double sigma_m, unsigned seed, std::vector<Eigen::Isometry3d>* truth) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise_m(0.0, sigma_m);
  Poses noisy;
  for (int k = 0; k < frames; ++k) {
    truth->push_back(swing(k));
    Eigen::Isometry3d T = swing(k);
    T.translation() += Eigen::Vector3d(noise_m(rng), noise_m(rng), noise_m(rng));
    noisy.emplace_back(frameStampNs(k), T);
  }
  return noisy;
}

// White noise of 6 mm per axis on a swinging camera (the per-frame noise of fr1/rpy, about 15 mm of
// second difference): +-75 ms (5 poses) divides it by about sqrt(5), the swing's curvature adding
// about 1 mm. Measured 11.1 -> 6.0 mm (0.86 mm without noise), the same with and without the
// outlier weights (Gaussian noise has no outliers to weigh down). Bound: at most 0.6 times the
// noise (fails with the smoothing off or down to +-1 pose). A constant velocity is followed
// exactly, also at the ends where the window is one-sided.
TEST(SmoothPositions, DividesWhiteNoiseAndFollowsAConstantVelocity) {
  std::vector<Eigen::Isometry3d> truth;
  const Poses noisy = noisySwing(90, 0.006, 7, &truth);
  Poses line;
  for (int k = 0; k < 90; ++k) line.emplace_back(frameStampNs(k), pose(0.02 * k, 0.0));
  std::vector<int> segments(90, 0);
  const double before_m = positionErrorRmsM(noisy, truth);
  for (const double outlier_sigmas : {0.0, 3.0}) {
    SCOPED_TRACE("outlier_sigmas " + std::to_string(outlier_sigmas));
    const PositionSmoothing smoothing{0.075, outlier_sigmas};
    Poses smoothed = noisy;
    smoothPositions(smoothing, segments, &smoothed);
    const double after_m = positionErrorRmsM(smoothed, truth);
    Poses exact;
    for (int k = 0; k < 90; ++k) exact.emplace_back(frameStampNs(k), truth[static_cast<std::size_t>(k)]);
    smoothPositions(smoothing, segments, &exact);
    std::printf("outlier sigmas %.0f: position error rms %.2f mm noisy, %.2f mm smoothed (%.2f mm without noise)\n",
                outlier_sigmas, 1e3 * before_m, 1e3 * after_m, 1e3 * positionErrorRmsM(exact, truth));
    EXPECT_LT(after_m, 0.6 * before_m);
    for (std::size_t k = 0; k < smoothed.size(); ++k) {
      EXPECT_TRUE(smoothed[k].second.linear().isApprox(noisy[k].second.linear(), 1e-15)) << "rotation changed at " << k;
    }
    Poses fitted = line;
    smoothPositions(smoothing, segments, &fitted);
    for (std::size_t k = 0; k < line.size(); ++k) {
      EXPECT_LT((fitted[k].second.translation() - line[k].second.translation()).norm(), 1e-9) << "pose " << k;
    }
  }
  Poses off = noisy;
  smoothPositions(PositionSmoothing{0.0, 3.0}, segments, &off);
  EXPECT_EQ(positionErrorRmsM(off, truth), before_m);
}

// One frame 5 cm off (a blurred frame in a fast turn) among poses with 1.5 mm of noise per axis.
// The plain fit at each of the four neighbours whose window holds it is the window's mean, so it
// moves each of them by a fifth of the error (1 cm) and takes the frame itself only to 1.2 cm;
// with the outlier weights (3 sigma) its weight falls below 0.1. Bounds: the frame moves each
// neighbour's fit by at most 2 mm (compared with the same poses without it) and keeps at most
// 6 mm of its own error; the plain fit, on the same poses, must move a neighbour by more than
// 8 mm and keep more than 10 mm, so the bounds can fail.
TEST(SmoothPositions, AFrameCentimetresOffNeitherPullsItsNeighboursNorKeepsItsError) {
  std::vector<Eigen::Isometry3d> truth;
  const Poses clean = noisySwing(90, 0.0015, 11, &truth);
  constexpr int kOff = 45;
  Poses with_outlier = clean;
  with_outlier[kOff].second.translation() += Eigen::Vector3d(0.05, 0.0, 0.0);
  std::vector<int> segments(90, 0);
  const auto at = [](const Poses& poses, int k) { return poses[static_cast<std::size_t>(k)].second.translation(); };
  for (const double outlier_sigmas : {0.0, 3.0}) {
    const PositionSmoothing smoothing{0.075, outlier_sigmas};
    Poses without = clean, with = with_outlier;
    smoothPositions(smoothing, segments, &without);
    smoothPositions(smoothing, segments, &with);
    double pull_m = 0.0;
    for (int k = kOff - 2; k <= kOff + 2; ++k) {
      if (k != kOff) pull_m = std::max(pull_m, (at(with, k) - at(without, k)).norm());
    }
    const double own_m = (at(with, kOff) - truth[kOff].translation()).norm();
    std::printf("outlier sigmas %.0f: neighbours moved by up to %.2f mm, the frame itself %.2f mm off\n",
                outlier_sigmas, 1e3 * pull_m, 1e3 * own_m);
    if (outlier_sigmas > 0.0) {
      EXPECT_LT(pull_m, 0.002);
      EXPECT_LT(own_m, 0.006);
    } else {
      EXPECT_GT(pull_m, 0.008);
      EXPECT_GT(own_m, 0.010);
    }
  }
}

// A jump between segments (a relocalisation) stays a jump, and a lost frame's held pose is neither
// changed nor used.
TEST(SmoothPositions, KeepsSegmentsApartAndLostPosesAsTheyAre) {
  Poses poses;
  std::vector<int> segments;
  for (int k = 0; k < 20; ++k) {
    const bool second = k >= 10;
    poses.emplace_back(frameStampNs(k), pose(0.01 * k + (second ? 0.5 : 0.0), 0.0));
    segments.push_back(second ? 1 : 0);
  }
  segments[5] = -1;
  poses[5].second.translation().x() = 3.0;  // a lost frame's held pose, far off the line
  const Poses before = poses;
  smoothPositions(PositionSmoothing{0.075, 3.0}, segments, &poses);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    EXPECT_LT((poses[k].second.translation() - before[k].second.translation()).norm(), 1e-9) << "pose " << k;
  }
}

// The recorder splits segments where a frame was discontinuous or lost.
TEST(TrajectoryRecorder, SmoothsWithinSegmentsOnly) {
  TrackerMap map{TrackingOptions()};
  MapKeyframe kf0;
  kf0.id = 0;
  map.addKeyframe(kf0);
  TrajectoryRecorder recorder;
  for (int k = 0; k < 12; ++k) {
    TrackingResult r = tracked(frameStampNs(k), 0, kf0.T_world_camera, pose(0.01 * k + (k >= 6 ? 0.4 : 0.0), 0.0));
    r.discontinuous = k == 6;  // relocalised 0.4 m away
    recorder.add(r);
  }
  const Poses raw = recorder.finalPoses(map), smoothed = recorder.finalPoses(map, PositionSmoothing{0.075, 3.0});
  ASSERT_EQ(smoothed.size(), raw.size());
  for (std::size_t k = 0; k < raw.size(); ++k) {
    EXPECT_LT((smoothed[k].second.translation() - raw[k].second.translation()).norm(), 1e-9) << "pose " << k;
  }
}

// finalPoses from a record on (what the rviz path redraws) is the tail of the whole trajectory:
// the same poses, re-expressed and fitted alike, once the fit's window (+-2 poses at 30 Hz) lies
// inside the tail; an index past the end gives none.
TEST(TrajectoryRecorder, FinalPosesFromARecordOnAreTheTailOfTheWhole) {
  TrackerMap map{TrackingOptions()};
  MapKeyframe kf0;
  kf0.id = 0;
  kf0.T_world_camera = pose(0.2, 0.1);
  map.addKeyframe(kf0);
  std::vector<Eigen::Isometry3d> truth;
  const Poses noisy = noisySwing(40, 0.006, 3, &truth);
  TrajectoryRecorder recorder;
  for (const auto& [stamp_ns, T_world_camera] : noisy) {
    recorder.add(tracked(stamp_ns, 0, kf0.T_world_camera, T_world_camera));
  }
  const PositionSmoothing smoothing{0.075, 0.0};
  const Poses whole = recorder.finalPoses(map, smoothing);
  constexpr std::size_t kFirst = 25;
  const Poses tail = recorder.finalPoses(map, smoothing, kFirst);
  ASSERT_EQ(tail.size(), whole.size() - kFirst);
  for (std::size_t i = 2; i < tail.size(); ++i) {
    EXPECT_EQ(tail[i].first, whole[kFirst + i].first);
    EXPECT_LT((tail[i].second.translation() - whole[kFirst + i].second.translation()).norm(), 1e-12) << "pose " << i;
  }
  EXPECT_TRUE(recorder.finalPoses(map, smoothing, whole.size() + 1).empty());
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
