/// Tracking benchmark: RgbdOdometry alone on a TUM-layout folder (no mask), per-stage timing and
/// ATE; option overrides make it the feature-count scaling and ablation bench.
///
/// Usage: tracking_bench_sequence --dataset DIR [--camera NAME_OR_YAML] [--out TRAJ.txt]
///        [--bonn] [--set KEY VALUE]...   (KEY = any TrackingOptions field, e.g. num_features)
/// Prints one line: frames, OK, lost, keyframes, loops, ATE RMSE [cm] of the final trajectory
/// (frames follow later corrections of their keyframe; "online" = poses at frame time; rigid
/// alignment), the first-to-last-frame drift [cm] (the loop gap on a closed loop; --bonn
/// applies the Bonn ground-truth correction), median ms per stage (features = pyramid + ORB +
/// undistortion, matching, pnp, refine = motion-only BA, local_ba, loop) and median / mean total.

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "dypho/tools/camera_config.h"
#include "dypho/tools/evaluation.h"
#include "dypho/common/trajectory_io.h"
#include "dypho/tools/tum_dataset.h"
#include "dypho/tracking/rgbd_odometry.h"
#include "dypho/tracking/trajectory_recorder.h"
#include "dypho/tracking/tracking_options_fields.h"
#include "help_flag.h"

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// Sets the TrackingOptions field `key` from text; false when no field has that name.
bool setOption(dypho::tracking::TrackingOptions* o, const std::string& key, const std::string& value) {
  bool found = false;
  dypho::tracking::visitOptions(*o, [&](const char* name, auto& field, const char*) {
    if (key != name) return;
    std::istringstream in(value);
    in >> std::boolalpha >> field;
    found = !in.fail();
  });
  return found;
}

}  // namespace

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: tracking_bench_sequence --dataset DIR [--camera NAME_OR_YAML] [--out TRAJ.txt]\n"
    "                               [--bonn] [--set KEY VALUE]...   (KEY = any TrackingOptions field)\n"
    "RgbdOdometry alone (no mask) on a TUM-layout folder: one line with frames, OK, lost, keyframes,\n"
    "loops, ATE RMSE [cm], first-to-last drift [cm] and median ms per stage. --bonn applies the Bonn\n"
    "ground-truth correction.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  namespace dt = dypho::tools;
  std::string dataset, camera_name, out;
  bool bonn = false;
  dypho::tracking::TrackingOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (key == "--bonn") {
      bonn = true;
    } else if (key == "--set" && i + 2 < argc) {
      if (!setOption(&options, argv[i + 1], argv[i + 2])) {
        std::cerr << "unknown option or bad value: " << argv[i + 1] << " " << argv[i + 2] << "\n";
        return 2;
      }
      i += 2;
    } else if (i + 1 < argc && (key == "--dataset" || key == "--camera" || key == "--out")) {
      (key == "--dataset" ? dataset : key == "--camera" ? camera_name : out) = argv[++i];
    } else {
      std::cerr << "usage: tracking_bench_sequence --dataset DIR [--camera NAME] [--out TRAJ] "
                   "[--bonn] [--set KEY VALUE]...\n";
      return 2;
    }
  }
  if (dataset.empty()) {
    std::cerr << "--dataset is required\n";
    return 2;
  }
  try {
    options.validate();
    if (camera_name.empty()) {
      const auto detected = dt::detectCameraName(dataset);
      if (!detected) throw std::runtime_error("cannot detect the camera; pass --camera");
      camera_name = *detected;
    }
    const dt::CameraConfig camera = dt::loadCameraConfig(dt::resolveCameraConfig(camera_name, dt::defaultConfigDir()));
    const dt::TumDataset data = dt::TumDataset::open(dataset, camera);
    dypho::tracking::RgbdOdometry odometry(options);
    std::map<std::string, std::vector<double>> stages;
    dypho::tracking::TrajectoryRecorder recorder;
    int ok = 0, lost = 0, keyframes = 0, loops = 0;
    for (std::size_t i = 0; i < data.size(); ++i) {
      const dypho::RgbdFrame frame = data.load(i);
      const auto r = odometry.track(frame, cv::Mat());
      stages["features"].push_back(r.times.features);
      stages["matching"].push_back(r.times.matching);
      stages["pnp"].push_back(r.times.pnp);
      stages["refine"].push_back(r.times.refine);
      stages["local_ba"].push_back(r.times.local_ba);
      stages["loop"].push_back(r.times.loop);
      stages["total"].push_back(r.times.total);
      ok += r.state == dypho::tracking::TrackingState::kOk;
      lost += r.state == dypho::tracking::TrackingState::kLost;
      keyframes += r.is_keyframe;
      loops += r.loop_closed;
      recorder.add(r);
    }
    // Final trajectory: each tracked frame follows the later local-BA / loop corrections of its
    // reference keyframe (what ORB-SLAM saves), its position fitted in time; `trajectory` holds
    // the poses at frame time.
    const std::vector<dypho::StampedPose> final_trajectory = dypho::toStampedPoses(
        recorder.finalPoses(odometry.map(), dypho::tracking::positionSmoothing(odometry.options())));
    const std::vector<dypho::StampedPose> trajectory = dypho::toStampedPoses(recorder.onlinePoses());
    if (!out.empty()) dypho::writeTumTrajectory(out, final_trajectory);
    double ate_cm = -1, ate_online_cm = -1, end_drift_cm = -1;
    if (!data.groundtruth().empty()) {
      const auto gt = bonn ? dt::applyBonnCorrection(data.groundtruth()) : data.groundtruth();
      ate_cm = 100.0 * dt::computeAte(final_trajectory, gt).rmse_m;
      ate_online_cm = 100.0 * dt::computeAte(trajectory, gt).rmse_m;
      // Drift between the first and the last tracked frame (the gap a loop closure closes on a
      // loop): translation of (T_gt_first^-1 T_gt_last)^-1 (T_first^-1 T_last).
      if (final_trajectory.size() >= 2) {
        const auto& first = final_trajectory.front();
        const auto& last = final_trajectory.back();
        const auto nearest = [&gt](double t_s) -> std::optional<Eigen::Isometry3d> {
          const auto it = std::min_element(gt.begin(), gt.end(), [t_s](const auto& a, const auto& b) {
            return std::abs(a.stamp_s - t_s) < std::abs(b.stamp_s - t_s);
          });
          if (it == gt.end() || std::abs(it->stamp_s - t_s) > 0.02) return std::nullopt;
          return it->T_world_camera;
        };
        const auto gt_first = nearest(first.stamp_s);
        const auto gt_last = nearest(last.stamp_s);
        if (gt_first && gt_last) {
          const Eigen::Isometry3d error =
              (gt_first->inverse() * *gt_last).inverse() * (first.T_world_camera.inverse() * last.T_world_camera);
          end_drift_cm = 100.0 * error.translation().norm();
        }
      }
    }
    const auto& total = stages["total"];
    std::cout << "frames " << data.size() << " ok " << ok << " lost " << lost << " keyframes " << keyframes << " loops "
              << loops << " ate_cm " << ate_cm << " (online " << ate_online_cm << ") end_drift_cm " << end_drift_cm
              << " | median_ms";
    for (const char* s : {"features", "matching", "pnp", "refine", "local_ba", "loop", "total"}) {
      std::cout << " " << s << " " << median(stages[s]);
    }
    std::cout << " | mean_total_ms "
              << std::accumulate(total.begin(), total.end(), 0.0) / std::max<size_t>(1, total.size())
              << " max_total_ms " << *std::max_element(total.begin(), total.end()) << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
