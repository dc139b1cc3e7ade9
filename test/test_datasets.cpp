/// Runs the installed command `dypho_run_dataset` on real and synthetic sequences and bounds the
/// ATE. The real sequences live in ../shared beside the repository; when that folder is absent
/// the tests are skipped with a message saying so (never silently passed). The generator's
/// still-camera crowds are in test_still_camera_crowd.cpp.

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

#include "dataset_run.h"
#include "dypho/common/trajectory_io.h"
#include "dypho/tools/evaluation.h"

namespace DYPHO_UNITY_ID {

using dypho::dataset_run::ateOf;
using dypho::dataset_run::exists;
using dypho::dataset_run::kTrajectoryOnly;
using dypho::dataset_run::readText;
using dypho::dataset_run::runDataset;
using dypho::dataset_run::sharedDir;
using dypho::dataset_run::testOut;

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

/// Frames of makeSynthetic's sequence: the runs on it use at most 40 (the generator takes about
/// 0.1 s of CPU per frame; three of the sequence at 150 frames were about 30 s of the suite).
constexpr int kShortSequenceFrames = 45;

/// A fresh kShortSequenceFrames-frame synthetic sequence in testOut()/<name> (no bag).
std::string makeSynthetic(const std::string& name) {
  const std::string data = testOut() + "/" + name;
  const std::string cmd = std::string("rm -rf '") + data + "' && '" + DYPHO_SYNTH + "' --out '" + data + "' --frames " +
                          std::to_string(kShortSequenceFrames) +
                          " --motion halfsphere --people 1 --seed 5 --no-bag > /dev/null";
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
  ASSERT_EQ(rgb.size(), static_cast<std::size_t>(kShortSequenceFrames));
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
// test_datasets about even: the detector's Bonn run before fr1's, the bad-input checks before the
// resumed session (on the 2-core VM 417 and 400 s, against 426 and 334 s in the order before; the
// longest test, the default input with its map over the whole sequence, 130 s beside the other
// shard).
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
                             "for i in $(seq 600); do grep -q '21/" +
                             std::to_string(kShortSequenceFrames) + "' '" + log +
                             "' && break; sleep 0.1; done; "
                             "kill -INT $pid; wait $pid";
  std::ofstream(out + "_sigint.sh") << script << "\n";
  const int status = std::system(("bash '" + out + "_sigint.sh'").c_str());
  std::cout << readText(log) << std::endl;
  ASSERT_EQ(WEXITSTATUS(status), 130) << "the run was not stopped by SIGINT (finished, or failed)";
  const auto poses = dypho::readTumTrajectory(out + "/trajectory.txt");
  EXPECT_GT(poses.size(), 0u);
  EXPECT_LT(poses.size(), static_cast<std::size_t>(kShortSequenceFrames));
  EXPECT_TRUE(exists(out + "/map.ply"));
  EXPECT_NE(readText(log).find("stopped by a signal"), std::string::npos);
}

TEST(DatasetRun, BadInputGivesClearErrorAndNonZeroExit) {
  const std::string out = testOut() + "/bad";
  EXPECT_NE(runDataset("/nonexistent/folder", out), 0);
  EXPECT_NE(readText(out + "/log.txt").find("/nonexistent/folder"), std::string::npos);
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
  EXPECT_NE(readText(out + "/log.txt").find("--camera"), std::string::npos);
  // An option given twice is refused, not silently replaced by the second value.
  EXPECT_NE(runDataset(empty, out, "--camera tum_fr1 --config a.yaml --config b.yaml"), 0);
  EXPECT_NE(readText(out + "/log.txt").find("--config given twice"), std::string::npos);
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

}  // namespace DYPHO_UNITY_ID
