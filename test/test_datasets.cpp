/// Runs the installed command `dypho_run_dataset` on real and synthetic sequences and bounds the
/// ATE. The real sequences live in ../shared beside the repository; when that folder is absent
/// the tests are skipped with a message saying so (never silently passed).

#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tools/evaluation.h"
#include "dypho/common/trajectory_io.h"

namespace DYPHO_UNITY_ID {

// ATE bounds [m] (RMSE after rigid alignment of trajectory.txt, the final trajectory), default
// settings (flow mask). Runs are deterministic for a build; fr1's bound is the measured value plus
// about 45 % (fr1/rpy is sensitive to which frames become keyframes). Measured
// (docs/journal/benchmarks-2026.md, sections 14, 15 and 20): fr1 1.44 cm (1.61 cm with keyframes
// postponed from 1.5 deg/frame, 2.06 cm before the mask's motion tolerance, 3.12 cm before the
// rolling-shutter model and the growth limit; the mean over the window and 14 frame-removal
// variants 3.70 -> 2.23 -> 1.42 cm), synthetic 0.46 cm (bag: 0.45 cm).
constexpr double DYPHO_FR1_ATE_BOUND_M = 0.021;
// fr1/rpy's desk is static: the mean share of the view the mask held in the same run. Measured
// 1.28 % with the background warped with the motion fitted to the flow (3.18 % with the tracker's
// constant-velocity prediction: on the frames after a jerk the desk stayed masked, up to 30 % of
// the view). The bound leaves room for another machine's flow, and fails when the desk's false
// positives come back.
constexpr double DYPHO_FR1_MASKED_BOUND = 0.02;
// Bonn crowd with the YOLOX-nano detector from ../shared/models added to the flow mask: the
// issue's target (2 cm) is the bound; measured 1.41 cm (1.64 cm before the mask's motion
// tolerance, 1.42 cm before the rolling-shutter model).
constexpr double DYPHO_BONN_ATE_BOUND_M = 0.02;
// The generator's fast hand-held turns seen through a 30 ms rolling shutter (150 frames, the
// ground-truth mask so that only tracking is judged): measured 3.15 cm with the camera file's
// readout, 58.3 cm with a global-shutter model. The bound is the measured value plus about a third
// (the skewed images make the run sensitive to floating point, as fr1's); the global-shutter run
// must stay above 20 cm so that the case keeps showing what the model is for.
constexpr double DYPHO_ROLLING_SHUTTER_ATE_BOUND_M = 0.05;
constexpr double DYPHO_ROLLING_SHUTTER_WITHOUT_MODEL_MIN_M = 0.20;
// Synthetic: the issue's own target (1 cm) is the bound; measured 0.46 cm.
constexpr double DYPHO_SYNTH_ATE_BOUND_M = 0.01;
// Synthetic: the map at every 10th frame, novel views (expectMapViews says why 3 dB below).
// Measured 27.36 dB (novel views, 2-core VM); the bound is about 3 dB below.
constexpr double kSynthViewPsnrBoundDb = 24.0;
// Bonn crowd with the flow mask only (no network): the goal (3 cm) is the bound;
// measured 1.30 cm (1.57 cm before the mask's motion tolerance, 2.00 cm before the
// rolling-shutter model, 6.85 cm before the crowd-aware global-motion fit).
constexpr double DYPHO_BONN_FLOW_ATE_BOUND_M = 0.03;
// Synthetic hard cases (static camera, people in view from frame 0, flow mask only): the issue's
// goal (0.5 cm) is the bound; measured stop-and-go 0.13 cm, group 0.18 cm, towards the camera
// 0.17 cm (150 frames, seed 1); 6 people crossing, seed 2 (the start in a crowd: the camera's
// motion is not found on frame 1) 0.12 cm, 8.84 cm before unknown_motion_is_dynamic.
constexpr double DYPHO_HARD_CASE_ATE_BOUND_M = 0.005;

/// Where the runs write: DYPHO_TEST_OUT, or its shard<i> subfolder when gtest runs this process as
/// one of several shards side by side (scripts/run_gtest.sh --shards): every run, and every
/// generated sequence, then belongs to one process.
std::string testOut() {
  const char* index = std::getenv("GTEST_SHARD_INDEX");
  const char* total = std::getenv("GTEST_TOTAL_SHARDS");
  if (index == nullptr || total == nullptr || std::atoi(total) <= 1) return DYPHO_TEST_OUT;
  return std::string(DYPHO_TEST_OUT) + "/shard" + index;
}

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

std::string sharedDir() {
  const char* env = std::getenv("DYPHO_SHARED_DIR");
  return env != nullptr ? env : DYPHO_SHARED_DIR;
}

/// The trajectory tests run mask and tracking only (--no-map): with R_d off (the default) the map
/// does not feed back into the trajectory (SyntheticDefaultInput checks that the trajectory is the
/// same with and without it), and training the map took most of each run's time.
constexpr const char* kTrajectoryOnly = "--no-map";

/// Runs dypho_run_dataset and returns its exit code; output goes to <out>/log.txt.
int runDataset(const std::string& dataset, const std::string& out, const std::string& extra = "") {
  const std::string cmd = std::string("mkdir -p '") + out + "' && '" + DYPHO_RUN_DATASET + "' --dataset '" + dataset +
                          "' --out '" + out + "' --quiet " + extra + " > '" + out + "/log.txt' 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream log(out + "/log.txt");
  std::cout << log.rdbuf() << std::endl;
  return WEXITSTATUS(status);
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// Mean of the `column` (by header name) of a runner's timing.csv; -1 when the file or the column
/// is missing or it has no row.
double meanOfColumn(const std::string& csv_path, const std::string& column) {
  std::ifstream in(csv_path);
  std::string line, cell;
  if (!std::getline(in, line)) return -1.0;
  int index = -1;
  std::istringstream header(line);
  for (int i = 0; std::getline(header, cell, ','); ++i) {
    if (cell == column) index = i;
  }
  if (index < 0) return -1.0;
  double sum = 0.0;
  int rows = 0;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    for (int i = 0; std::getline(row, cell, ','); ++i) {
      if (i == index) {
        sum += std::atof(cell.c_str());
        ++rows;
      }
    }
  }
  return rows > 0 ? sum / rows : -1.0;
}

double ateOf(const std::string& out, const std::vector<dypho::StampedPose>& gt) {
  const auto est = dypho::readTumTrajectory(out + "/trajectory.txt");
  return dypho::tools::computeAte(est, gt).rmse_m;
}

/// "PSNR x dB ... coverage y %" of the `label` line ("all", "keyframes", "novel") of a map-view
/// report (view_evaluation.txt or dypho_evaluate_map's output); {views, psnr, coverage}, or
/// views -1 when the line is missing.
std::array<double, 3> viewSummary(const std::string& report, const std::string& label) {
  std::istringstream in(report);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t at = line.find(label + " ");
    if (line.find(" views: PSNR ") == std::string::npos || at == std::string::npos || at > 24) continue;
    double views = 0, psnr = 0, coverage = 0;
    const std::string rest = line.substr(at + label.size());
    if (std::sscanf(rest.c_str(), " %lf views: PSNR %lf", &views, &psnr) != 2) continue;
    if (std::sscanf(line.substr(line.find("coverage")).c_str(), "coverage %lf", &coverage) != 1) continue;
    return {views, psnr, coverage};
  }
  return {-1.0, 0.0, 0.0};
}

/// The Gaussian map of real frames: fr1/rpy's first 40 frames (11 keyframes) with the map on,
/// scored at every 10th frame by the runner (view_evaluation.txt). Measured on the 2-core VM:
/// 25.38 dB over the 4 views, coverage 100 %; the bound is 3 dB below, as for the synthetic map
/// (expectMapViews), and coverage must be >= 95 %. The map's training is most of a run's time, so
/// the trajectory tests run without it; the first 40 frames are the map's check on real data.
constexpr double kFr1MapPsnrBoundDb = 22.4;

void expectRealMap(const std::string& data) {
  const std::string out = testOut() + "/fr1_map";
  ASSERT_EQ(runDataset(data, out, "--max-frames 40"), 0);
  for (const char* f : {"map.pcd", "map.ply", "view_evaluation.txt"}) EXPECT_TRUE(exists(out + "/" + f)) << f;
  const std::string report = readText(out + "/view_evaluation.txt");
  const auto all = viewSummary(report, "all");
  EXPECT_EQ(all[0], 4.0) << report;
  EXPECT_GE(all[1], kFr1MapPsnrBoundDb) << report;
  EXPECT_GE(all[2], 95.0) << report;
}

TEST(DatasetRun, TumFr1RpyFirst150) {
  const std::string data = sharedDir() + "/data/tum_fr1_rpy_first150";
  if (!exists(data)) GTEST_SKIP() << "SKIPPED: " << data << " not found (needs ../shared beside the repo)";
  const std::string out = testOut() + "/fr1";
  ASSERT_EQ(runDataset(data, out, kTrajectoryOnly), 0);
  const auto est = dypho::readTumTrajectory(out + "/trajectory.txt");
  EXPECT_EQ(est.size(), 150u);  // one line per processed frame
  for (const char* f : {"timing.csv", "keyframes.txt", "evaluation.txt", "trajectory.png"}) {
    EXPECT_TRUE(exists(out + "/" + f)) << f;
  }
  const auto gt = dypho::readTumTrajectory(data + "/groundtruth.txt");
  const double ate = ateOf(out, gt);
  std::cout << "fr1/rpy first 150: ATE RMSE " << ate * 100 << " cm\n";
  EXPECT_LT(ate, DYPHO_FR1_ATE_BOUND_M);
  // The desk is static: every pixel the mask tracking used holds is a false positive.
  const double masked = meanOfColumn(out + "/timing.csv", "masked_fraction");
  std::cout << "fr1/rpy first 150: mean masked fraction " << masked << "\n";
  EXPECT_GE(masked, 0.0) << "timing.csv without masked_fraction";
  EXPECT_LE(masked, DYPHO_FR1_MASKED_BOUND);
  expectRealMap(data);
}

TEST(DatasetRun, BonnCrowdFrames200to399WithDetector) {
  const std::string data = sharedDir() + "/data/rgbd_bonn_crowd_frames200to399";
  const std::string model = sharedDir() + "/models/yolox_nano.onnx";
  if (!exists(data)) GTEST_SKIP() << "SKIPPED: " << data << " not found (needs ../shared beside the repo)";
  if (!exists(model)) GTEST_SKIP() << "SKIPPED: " << model << " not found (needs ../shared beside the repo)";
  const std::string out = testOut() + "/bonn";
  ASSERT_EQ(std::system(("mkdir -p '" + out + "'").c_str()), 0);
  {
    std::ofstream config(out + "/detector.yaml");
    config << "mask:\n  yolo_model_path: \"" << model << "\"\n";
  }
  ASSERT_EQ(runDataset(data, out, std::string(kTrajectoryOnly) + " --config '" + out + "/detector.yaml'"), 0);
  const auto gt = dypho::tools::applyBonnCorrection(dypho::readTumTrajectory(data + "/groundtruth.txt"));
  const double ate = ateOf(out, gt);
  std::cout << "Bonn crowd 200-399: ATE RMSE " << ate * 100 << " cm (Bonn correction applied)\n";
  EXPECT_LT(ate, DYPHO_BONN_ATE_BOUND_M);
}

TEST(DatasetRun, BonnCrowdFrames200to399FlowMaskOnly) {
  const std::string data = sharedDir() + "/data/rgbd_bonn_crowd_frames200to399";
  if (!exists(data)) GTEST_SKIP() << "SKIPPED: " << data << " not found (needs ../shared beside the repo)";
  const std::string out = testOut() + "/bonn_flow";
  ASSERT_EQ(runDataset(data, out, kTrajectoryOnly), 0);
  const auto gt = dypho::tools::applyBonnCorrection(dypho::readTumTrajectory(data + "/groundtruth.txt"));
  const double ate = ateOf(out, gt);
  std::cout << "Bonn crowd 200-399, flow mask only: ATE RMSE " << ate * 100 << " cm (Bonn correction applied)\n";
  EXPECT_LT(ate, DYPHO_BONN_FLOW_ATE_BOUND_M);
}

TEST(DatasetRun, RollingShutterFastTurnsAreTracked) {
  const std::string data = testOut() + "/rolling_shutter";
  const std::string make = std::string("rm -rf '") + data + "' && '" + DYPHO_SYNTH + "' --out '" + data +
                           "' --frames 150 --motion fast-rpy --rolling-shutter-ms 30 --people 2 --seed 1 --no-bag > '" +
                           testOut() + "/rolling_shutter_synth.txt' 2>&1";
  ASSERT_EQ(std::system(make.c_str()), 0);
  ASSERT_NE(readText(data + "/camera.yaml").find("rolling_shutter_readout_ms: 30"), std::string::npos);
  const auto gt = dypho::readTumTrajectory(data + "/groundtruth.txt");
  const std::string out = data + "_run";
  ASSERT_EQ(runDataset(data, out, std::string(kTrajectoryOnly) + " --mask gt"), 0);
  const double ate = ateOf(out, gt);
  const std::string global = data + "_global_shutter";
  ASSERT_EQ(std::system(("mkdir -p '" + global + "'").c_str()), 0);
  std::ofstream(global + "/config.yaml") << "tracking:\n  rolling_shutter_readout_ms: 0\n";
  ASSERT_EQ(runDataset(data, global, std::string(kTrajectoryOnly) + " --mask gt --config '" + global + "/config.yaml'"),
            0);
  const double ate_global = ateOf(global, gt);
  std::cout << "fast turns, 30 ms rolling shutter: ATE RMSE " << ate * 100 << " cm with the model, " << ate_global * 100
            << " cm with a global-shutter model\n";
  EXPECT_LT(ate, DYPHO_ROLLING_SHUTTER_ATE_BOUND_M);
  EXPECT_GT(ate_global, DYPHO_ROLLING_SHUTTER_WITHOUT_MODEL_MIN_M);
}

namespace DYPHO_UNITY_ID {

/// A still camera's 150 frames with people in view from frame 0 (dypho_synth `args`, `seed`),
/// generated into testOut()/`name`; returns its folder ("" when generation failed).
std::string stillCameraCrowd(const std::string& name, const std::string& args, int seed) {
  const std::string dir = testOut() + "/" + name;
  const std::string cmd = std::string("rm -rf '") + dir + "' && '" + DYPHO_SYNTH + "' --out '" + dir +
                          "' --frames 150 --motion static --people-in-view " + args + " --seed " +
                          std::to_string(seed) + " --no-bag > /dev/null";
  return std::system(cmd.c_str()) == 0 ? dir : std::string();
}

}  // namespace DYPHO_UNITY_ID

/// Synthetic hard cases of a still camera in a crowd, flow mask only: a name and the
/// dypho_synth arguments.
struct HardCaseSpec {
  const char* name;
  const char* synth_args;
  int seed = 1;
};

class HardCase : public ::testing::TestWithParam<HardCaseSpec> {};

TEST_P(HardCase, FlowMaskOnlyStaysOnTheStaticRoom) {
  const std::string name = std::string("hard_") + GetParam().name;
  const std::string data = stillCameraCrowd(name, GetParam().synth_args, GetParam().seed);
  ASSERT_FALSE(data.empty());
  const std::string out = data + "_run";
  ASSERT_EQ(runDataset(data, out, kTrajectoryOnly), 0);
  const double ate = ateOf(out, dypho::readTumTrajectory(data + "/groundtruth.txt"));
  std::cout << name << ": ATE RMSE " << ate * 100 << " cm\n";
  EXPECT_LT(ate, DYPHO_HARD_CASE_ATE_BOUND_M);
}

// People pixels, mean / max share of the view (dypho_synth's summary).
INSTANTIATE_TEST_SUITE_P(
    StaticCamera, HardCase,
    ::testing::Values(HardCaseSpec{"stop_and_go", "--people 5 --walk stop-and-go --people-distance 0.9"},  // 34 / 54 %
                      HardCaseSpec{"group", "--people 4 --walk group"},                                    // 6 / 36 %
                      // 22 / 39 %; 0.56 cm (frame 1 6.7 cm off) while the static check
                      // judged the frame after the start by the dragged pose's own turn
                      HardCaseSpec{"group_seed9", "--people 4 --walk group", 9},
                      HardCaseSpec{"towards", "--people 4 --walk towards"},                    // 39 / 55 %
                      HardCaseSpec{"crossing6_seed2", "--people 6 --people-distance 0.9", 2},  // 31 / 55 %
                      // 41 / 65 %; 0.65 cm with object permanence (permanence_frames: 30)
                      HardCaseSpec{"crossing8_seed1", "--people 8 --people-distance 0.8", 1}),
    [](const ::testing::TestParamInfo<HardCaseSpec>& info) { return std::string(info.param.name); });

namespace DYPHO_UNITY_ID {

/// 8 people crossing a still camera's view from frame 0, generator seed 2 (docs/journal/benchmarks-2026.md
/// section 8), generated once.
std::string crossing8Seed2() {
  static const std::string data = stillCameraCrowd("crossing8_seed2", "--people 8 --people-distance 0.8", 2);
  return data;
}

/// ATE RMSE [m] of a trajectory-only run of `data` into `out` with the config YAML `config`
/// (written to out/config.yaml; empty = the defaults); -1 when the run failed.
double ateWithConfig(const std::string& data, const std::string& out, const std::string& config) {
  if (std::system(("rm -rf '" + out + "' && mkdir -p '" + out + "'").c_str()) != 0) return -1.0;
  std::string extra = kTrajectoryOnly;
  if (!config.empty()) {
    std::ofstream(out + "/config.yaml") << config;
    extra += " --config '" + out + "/config.yaml'";
  }
  if (runDataset(data, out, extra) != 0) return -1.0;
  return ateOf(out, dypho::readTumTrajectory(data + "/groundtruth.txt"));
}

/// The mask before object permanence and without the flow veto's still-camera exception, its
/// background warped with the prediction as given (as it was then): with the warp following the
/// flow's fit (background_warp_with_flow_fit) the missed people drag the pose less (8 crossing,
/// seed 2, without probation: 0.72 cm against 1.10 cm), and the mechanisms below, made for the
/// mask that missed them, are compared on the case they were made for.
constexpr const char* kMaskBeforePermanence =
    "mask:\n  permanence_frames: 0\n  veto_flow_while_still: true\n  background_warp_with_flow_fit: false\n";
/// Probation of new map points off (tracking option point_probation_frames): the comparisons of
/// the mechanisms that came before it run without it, because on their case probation alone
/// keeps the moving group from carrying the pose (both variants of each then give 0.53 cm).
constexpr const char* kNoProbation = "  point_probation_frames: 0\n";

/// One option's effect on `data`: runs it with `with.config` and with `without.config` (config
/// YAML, "" = the defaults), each into the run folder data + "_run_" + its name, prints both ATE
/// RMSEs of the unsmoothed trajectory after `label`, and expects the first at least `min_gain_m`
/// lower.
struct RunVariant {
  const char* name;    ///< run folder suffix and what the printed line calls it
  std::string config;  ///< config YAML ("" = the defaults)
};
/// `config` with the saved trajectory's smoothing off (trajectory_smoothing_s: 0), added to its
/// tracking: block or as one.
std::string withRawTrajectory(const std::string& config) {
  const std::string key = "  trajectory_smoothing_s: 0\n";
  const std::size_t at = config.find("tracking:\n");
  if (at == std::string::npos) return config + "tracking:\n" + key;
  return config.substr(0, at + 10) + key + config.substr(at + 10);
}

void expectLowerAte(const std::string& data, const std::string& label, const RunVariant& with,
                    const RunVariant& without, double min_gain_m) {
  // The mechanisms act on the tracked poses: both runs are read without the saved trajectory's
  // smoothing, which lowers both (stop-and-go seed 2: 0.21 and 0.31 cm become 0.14 and 0.23).
  const double ate_with = ateWithConfig(data, data + "_run_" + with.name, withRawTrajectory(with.config));
  const double ate_without = ateWithConfig(data, data + "_run_" + without.name, withRawTrajectory(without.config));
  ASSERT_GE(ate_with, 0.0) << with.name;
  ASSERT_GE(ate_without, 0.0) << without.name;
  std::cout << label << ": ATE RMSE " << ate_with * 100 << " cm (" << with.name << "), " << ate_without * 100 << " cm ("
            << without.name << ")\n";
  EXPECT_LT(ate_with, ate_without - min_gain_m);
}

}  // namespace DYPHO_UNITY_ID

// The static check's other starts (tracking option static_check_other_starts) on the case where
// they mattered: 8 people crossing, seed 2, with the mask that misses two of them on frames 37-52
// (kMaskBeforePermanence; with today's mask the case does not arise, 0.52 cm both ways). Moving
// matches drag the feature pose ~1.5 cm further on each of frames 47-51, out of the refinement's
// reach when it starts from the feature pose only. Measured 1.10 cm with, 1.32 cm without; the
// test asks for at least 1 mm less with them (single runs repeat to the last digit on one machine).
TEST(DatasetRun, StaticCheckStartingFromTheLastPoseHelpsInACrowd) {
  const std::string data = crossing8Seed2();
  ASSERT_FALSE(data.empty());
  const std::string mask_before = kMaskBeforePermanence;
  expectLowerAte(data, "8 crossing, seed 2, no probation", {"other_starts", mask_before + "tracking:\n" + kNoProbation},
                 {"feature_start_only", mask_before + "tracking:\n  static_check_other_starts: false\n" + kNoProbation},
                 0.001);
}

// No flow veto while the camera is still (mask option veto_flow_while_still) on 8 people
// crossing, seed 2: people the background model learnt (they stood there from the start, or stood
// still) were vetoed as noise as soon as the flow saw them move again, and dragged the pose.
// Measured 0.53 cm with the defaults, 1.10 cm without (0.48 cm with the defaults since
// moving_point_still_only, 0.49 cm since object permanence is off by default); the test asks for
// at least 3 mm less (half the measured gain; single runs repeat to the last digit). Compared with
// the background warped as predicted (background_warp_with_flow_fit off, as when the case was
// made: 0.48 cm against 1.10 cm): with the warp following the flow's fit the people drag the pose
// less without the veto's exception too (0.51 cm with it, 0.72 cm without).
TEST(DatasetRun, StillCameraMaskKeepsThePeopleTheBackgroundLearnt) {
  const std::string data = crossing8Seed2();
  ASSERT_FALSE(data.empty());
  const std::string no_probation = std::string("tracking:\n") + kNoProbation;
  const std::string warp_as_predicted = "mask:\n  background_warp_with_flow_fit: false\n";
  expectLowerAte(data, "8 crossing, seed 2, no probation, background warped as predicted",
                 {"warp_as_predicted_no_probation", warp_as_predicted + no_probation},
                 {"mask_before_no_probation", kMaskBeforePermanence + no_probation}, 0.003);
}

// Probation of new map points (tracking option point_probation_frames) on the same case with the
// mask before the still-camera changes (kMaskBeforePermanence), which misses two people on frames
// 37-52: while they drag the pose the camera seems to move, the points their keyframes gave them
// are still unverified, and the verified points' pose refutes them. Measured 0.53 cm with
// probation, 1.10 cm without; the test asks for at least 3 mm less (about half the gain; single
// runs repeat to the last digit on one machine).
TEST(DatasetRun, ProbationKeepsFreshPointsOfMissedPeopleFromCarryingThePose) {
  const std::string data = crossing8Seed2();
  ASSERT_FALSE(data.empty());
  const std::string mask_before = kMaskBeforePermanence;
  expectLowerAte(data, "8 crossing, seed 2, mask before", {"mask_before_probation", mask_before},
                 {"mask_before_no_probation", mask_before + "tracking:\n" + kNoProbation}, 0.003);
}

// Map points seen moving while the camera is still (tracking options moving_point_min_hits: 2,
// moving_point_still_only) on 5 people walking stop-and-go, seed 2: people who stood still when
// a keyframe was made walk on, and their points no longer carry the pose. Measured 0.20 cm with
// the defaults, 0.34 cm with the test off (moving_point_min_hits: 0); the test asks for at least
// 1 mm less (single runs repeat to the last digit on one machine).
TEST(DatasetRun, PointsSeenMovingBeforeAStillCameraAreCulled) {
  const std::string data =
      stillCameraCrowd("stop_and_go_seed2", "--people 5 --walk stop-and-go --people-distance 0.9", 2);
  ASSERT_FALSE(data.empty());
  expectLowerAte(data, "stop-and-go, seed 2", {"defaults", ""},
                 {"no_moving_points", "tracking:\n  moving_point_min_hits: 0\n"}, 0.001);
}

// A still camera's periodic keyframe waits while the static check disputes the pose (tracking
// option keyframe_static_doubt) on 5 people walking stop-and-go, seed 5: a person the background
// had learnt walks on and drags the pose over frames 76-80 (static agreement 0.99 -> 0.885, the
// refined pose 0.93: 0.044 more, under static_check_min_gain), and the periodic keyframe of frame
// 80 anchored the next frames to the dragged pose. Waiting one frame, the check corrects it first.
// Measured 0.31 cm with the defaults, 0.66 cm never postponing (keyframe_static_doubt: 0); the
// test asks for at least 1.5 mm less (under half the measured gain; single runs repeat to the
// last digit on one machine).
TEST(DatasetRun, PeriodicKeyframeWaitsForAnUndisputedPose) {
  const std::string data =
      stillCameraCrowd("stop_and_go_seed5", "--people 5 --walk stop-and-go --people-distance 0.9", 5);
  ASSERT_FALSE(data.empty());
  expectLowerAte(data, "stop-and-go, seed 5", {"defaults", ""},
                 {"never_postponed", "tracking:\n  keyframe_static_doubt: 0\n"}, 0.0015);
}

/// The map scored at every 10th frame (the runner's view_evaluation.txt), and the same map scored
/// by dypho_evaluate_map with the generator's exact masks. 150 frames: 15 views, most of them
/// novel (not keyframes). Measured on the 2-core VM: novel views 27.36 dB, coverage 99.9 %; the
/// bound is about 3 dB below (a map that lost its detail or half its colour fails it), coverage
/// must be >= 95 % (the bound: a hole in the room fails it), and the two tools, which
/// differ only in the mask (flow vs the generator's exact one; measured 26.62 vs 27.65 dB over all
/// views: the flow mask does not judge the first frame, so its people count there), must agree
/// within 1.5 dB.
void expectMapViews(const std::string& data, const std::string& out) {
  const std::string report = readText(out + "/view_evaluation.txt");
  const auto all = viewSummary(report, "all"), novel = viewSummary(report, "novel");
  std::cout << "map views: " << all[0] << " views, PSNR " << all[1] << " dB, coverage " << all[2] << " %; novel "
            << novel[0] << " views, PSNR " << novel[1] << " dB\n";
  EXPECT_EQ(all[0], 15.0) << report;
  EXPECT_GE(novel[0], 10.0) << "most frames never become keyframes";
  EXPECT_GE(all[2], 95.0) << "coverage";
  EXPECT_GE(novel[1], kSynthViewPsnrBoundDb);
  const std::string tool_out = out + "/evaluate_map.txt";
  const std::string cmd = std::string("'") + DYPHO_EVALUATE_MAP + "' --map '" + out + "/map.ply' --dataset '" + data +
                          "' --estimate '" + out + "/trajectory.txt' --masks '" + data + "' > '" + tool_out + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << readText(tool_out);
  const auto tool = viewSummary(readText(tool_out), "all");
  EXPECT_EQ(tool[0], 15.0) << readText(tool_out);
  EXPECT_NEAR(tool[1], all[1], 1.5) << readText(tool_out);
}

TEST(DatasetRun, SyntheticDefaultInput) {
  const std::string data = testOut() + "/synth";
  const std::string cmd = std::string("'") + DYPHO_SYNTH + "' --out '" + data +
                          "' --frames 150 --motion halfsphere --people 2 --seed 3 --no-bag > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string out = testOut() + "/synth_run";
  ASSERT_EQ(runDataset(data, out), 0);
  const double ate = ateOf(out, dypho::readTumTrajectory(data + "/groundtruth.txt"));
  std::cout << "synthetic halfsphere, 2 people: ATE RMSE " << ate * 100 << " cm\n";
  EXPECT_LT(ate, DYPHO_SYNTH_ATE_BOUND_M);
  EXPECT_TRUE(exists(out + "/map.ply"));
  expectMapViews(data, out);
  // Without the map: no map files, and the same trajectory to the last digit (what lets the other
  // trajectory tests skip the map).
  const std::string no_map = testOut() + "/synth_run_no_map";
  ASSERT_EQ(std::system(("rm -rf '" + no_map + "'").c_str()), 0);
  ASSERT_EQ(runDataset(data, no_map, kTrajectoryOnly), 0);
  EXPECT_FALSE(exists(no_map + "/map.ply"));
  EXPECT_FALSE(exists(no_map + "/map.pcd"));
  const std::string with_map_trajectory = readText(out + "/trajectory.txt");
  EXPECT_FALSE(with_map_trajectory.empty());
  EXPECT_EQ(readText(no_map + "/trajectory.txt"), with_map_trajectory);
}

/// A fresh 150-frame synthetic sequence in testOut()/<name> (no bag).
std::string makeSynthetic(const std::string& name) {
  const std::string data = testOut() + "/" + name;
  const std::string cmd = std::string("rm -rf '") + data + "' && '" + DYPHO_SYNTH + "' --out '" + data +
                          "' --frames 150 --motion halfsphere --people 1 --seed 5 --no-bag > /dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  return data;
}

std::vector<std::string> listedFiles(const std::string& list) {
  std::vector<std::string> files;
  std::ifstream in(list);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    files.push_back(line.substr(line.find(' ') + 1));
  }
  return files;
}

// A recording with one truncated PNG and one garbage line in rgb.txt: the run goes on, skips that
// frame and that line, names both, and writes every other frame's pose.
TEST(DatasetRun, UnreadableFrameAndGarbageLineAreSkippedAndNamed) {
  const std::string data = makeSynthetic("synth_damaged");
  const std::vector<std::string> rgb = listedFiles(data + "/rgb.txt");
  ASSERT_EQ(rgb.size(), 150u);
  // The first 40 frames are run (--max-frames; the whole list is still read, garbage line
  // included): frame 20 is damaged, and the map is built and written around the gap.
  const std::string damaged = data + "/" + rgb[20];
  ASSERT_EQ(::truncate(damaged.c_str(), 100), 0);  // a PNG cut off after 100 bytes
  const std::size_t garbage_line = [&] {           // the line the garbage is appended as
    std::ifstream in(data + "/rgb.txt");
    std::size_t lines = 0;
    for (std::string line; std::getline(in, line);) ++lines;
    return lines + 1;
  }();
  std::ofstream(data + "/rgb.txt", std::ios::app) << "this line is garbage\n";
  const std::string out = testOut() + "/synth_damaged_run";
  ASSERT_EQ(runDataset(data, out, "--max-frames 40"), 0);
  EXPECT_EQ(dypho::readTumTrajectory(out + "/trajectory.txt").size(), 39u);
  const std::string log = readText(out + "/log.txt");
  EXPECT_NE(log.find("1 unreadable and skipped"), std::string::npos);
  EXPECT_NE(log.find(rgb[20]), std::string::npos);                                    // the frame's file is named
  EXPECT_NE(log.find("rgb.txt:" + std::to_string(garbage_line)), std::string::npos);  // the garbage line is named
  EXPECT_TRUE(exists(out + "/map.ply"));
}

// After the unreadable-frame run in the file: gtest deals tests to its shards in file order (test
// i to shard i mod 2, scripts/run_gtest.sh --shards), and the order keeps the two shards of
// test_datasets about even (on the 2-core VM 266 and 298 s; the longest test, the default input
// with its map over the whole sequence, 95 s).
#ifdef DYPHO_SYNTH_BAG
TEST(DatasetRun, SyntheticBagInput) {
  // The bag written by dypho_synth for the graph test (TUM topic names, 32FC1 depth, camera_info);
  // its groundtruth.txt sits beside it. Same bound as the folder input: the bag stores the same
  // frames (depth as float metres instead of 16-bit PNG, which only removes quantisation).
  const std::string bag = DYPHO_SYNTH_BAG;
  const std::string out = testOut() + "/synth_bag_run";
  ASSERT_EQ(runDataset(bag, out, kTrajectoryOnly), 0);
  const std::string gt = bag.substr(0, bag.find_last_of('/')) + "/groundtruth.txt";
  const double ate = ateOf(out, dypho::readTumTrajectory(gt));
  std::cout << "synthetic bag (120 frames): ATE RMSE " << ate * 100 << " cm\n";
  EXPECT_LT(ate, DYPHO_SYNTH_ATE_BOUND_M);
}
#endif

// SIGINT (Ctrl-C) in the middle of a run: the processed frames' trajectory and map are written,
// and the exit status says the run was stopped (130).
TEST(DatasetRun, SigintWritesWhatWasProcessed) {
  const std::string data = makeSynthetic("synth_sigint");
  const std::string out = testOut() + "/synth_sigint_run";
  // Start the run, wait until its progress line reports frame 21, then send SIGINT.
  const std::string log = out + "/log.txt";
  ASSERT_EQ(std::system(("mkdir -p '" + out + "'").c_str()), 0);
  const std::string script = "mkdir -p '" + out + "'; '" + std::string(DYPHO_RUN_DATASET) + "' --dataset '" + data +
                             "' --out '" + out + "' > '" + log +
                             "' 2>&1 & pid=$!; "
                             "for i in $(seq 600); do grep -q '21/150' '" +
                             log +
                             "' && break; sleep 0.1; done; "
                             "kill -INT $pid; wait $pid";
  std::ofstream(out + "_sigint.sh") << script << "\n";
  const int status = std::system(("bash '" + out + "_sigint.sh'").c_str());
  std::cout << readText(log) << std::endl;
  ASSERT_EQ(WEXITSTATUS(status), 130) << "the run was not stopped by SIGINT (finished, or failed)";
  const auto poses = dypho::readTumTrajectory(out + "/trajectory.txt");
  EXPECT_GT(poses.size(), 0u);
  EXPECT_LT(poses.size(), 150u);
  EXPECT_TRUE(exists(out + "/map.ply"));
  EXPECT_NE(readText(log).find("stopped by a signal"), std::string::npos);
}

// A run's session resumed through the command line, localisation only: relocalised on the first
// frame, every frame posed, and the map written at the end is the loaded map.ply to the byte;
// --localization-only without --resume is refused. Short (40 frames, few training iterations).
TEST(DatasetRun, ResumedLocalisationOnlyLeavesTheSavedMap) {
  const std::string data = makeSynthetic("synth_session");
  const std::string out = testOut() + "/synth_session_run";
  ASSERT_EQ(std::system(("mkdir -p '" + out + "'").c_str()), 0);
  std::ofstream(out + "_fast.yaml") << "mapping:\n  iterations_per_keyframe: 5\n  final_refine_iterations: 5\n";
  const std::string common = "--max-frames 40 --eval-every 0 --config '" + out + "_fast.yaml'";
  ASSERT_EQ(runDataset(data, out, common), 0);
  for (const char* f : {"tracker.bin", "map.ply", "session.yaml"}) EXPECT_TRUE(exists(out + "/session/" + f)) << f;
  EXPECT_NE(readText(out + "/log.txt").find("session:      " + out + "/session ("), std::string::npos);

  const std::string again = testOut() + "/synth_session_localise";
  ASSERT_EQ(runDataset(data, again, common + " --resume '" + out + "' --localization-only"), 0);
  const std::string log = readText(again + "/log.txt");
  EXPECT_NE(log.find("relocalised at frame 0,"), std::string::npos);
  EXPECT_NE(log.find("frames:       40 of 40 processed (0 not tracked"), std::string::npos);
  EXPECT_EQ(dypho::readTumTrajectory(again + "/trajectory.txt").size(), 40u);
  const std::string loaded = readText(out + "/session/map.ply");
  EXPECT_FALSE(loaded.empty());
  EXPECT_TRUE(readText(again + "/map.ply") == loaded) << "localisation only changed the map";
  EXPECT_TRUE(readText(again + "/session/map.ply") == loaded);

  EXPECT_NE(runDataset(data, again, "--localization-only"), 0);
  EXPECT_NE(readText(again + "/log.txt").find("--localization-only needs --resume"), std::string::npos);

  // A refused session (no manifest there) fails before --out is made: no empty folder is left.
  const std::string refused = testOut() + "/synth_session_refused";
  ASSERT_EQ(std::system(("rm -rf '" + refused + "'").c_str()), 0);
  const std::string cmd = std::string("'") + DYPHO_RUN_DATASET + "' --dataset '" + data + "' --out '" + refused +
                          "' --quiet --resume '" + data + "' > '" + refused + ".log' 2>&1";
  EXPECT_NE(WEXITSTATUS(std::system(cmd.c_str())), 0);
  EXPECT_NE(readText(refused + ".log").find("no session in"), std::string::npos) << readText(refused + ".log");
  EXPECT_FALSE(exists(refused)) << "a refused --resume left " << refused;
}

TEST(DatasetRun, BadInputGivesClearErrorAndNonZeroExit) {
  const std::string out = testOut() + "/bad";
  EXPECT_NE(runDataset("/nonexistent/folder", out), 0);
  std::ifstream log(out + "/log.txt");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("/nonexistent/folder"), std::string::npos);
  // A folder without rgb.txt, with the camera given.
  const std::string empty = testOut() + "/empty_dataset";
  ASSERT_EQ(std::system(("mkdir -p '" + empty + "'").c_str()), 0);
  EXPECT_NE(runDataset(empty, out, "--camera tum_fr1"), 0);
  // A frame count that is not a whole number is refused by name, not read as its prefix ("1e").
  for (const char* bad : {"1e", "2.5", "-3", "x"}) {
    EXPECT_NE(runDataset(empty, out, std::string("--camera tum_fr1 --max-frames ") + bad), 0) << bad;
    EXPECT_NE(readText(out + "/log.txt").find("error: --max-frames needs a"), std::string::npos) << bad;
  }
  // No camera given and none detectable: asks for --camera.
  EXPECT_NE(runDataset(empty, out), 0);
  std::ifstream log2(out + "/log.txt");
  const std::string text2((std::istreambuf_iterator<char>(log2)), std::istreambuf_iterator<char>());
  EXPECT_NE(text2.find("--camera"), std::string::npos);
  // An option given twice is refused, not silently replaced by the second value.
  EXPECT_NE(runDataset(empty, out, "--camera tum_fr1 --config a.yaml --config b.yaml"), 0);
  EXPECT_NE(readText(out + "/log.txt").find("--config given twice"), std::string::npos);
}

}  // namespace DYPHO_UNITY_ID
