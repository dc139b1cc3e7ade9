/// The generator's still-camera crowds through the installed dypho_run_dataset: the flow mask
/// alone keeps the pose on the static room (hard cases, people in view from frame 0), and the
/// mechanisms made for such crowds are compared on and off on the cases they were made for.

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

#include "dataset_run.h"
#include "dypho/common/trajectory_io.h"

namespace DYPHO_UNITY_ID {

using dypho::dataset_run::ateOf;
using dypho::dataset_run::kTrajectoryOnly;
using dypho::dataset_run::runDataset;
using dypho::dataset_run::testOut;

// Synthetic hard cases (static camera, people in view from frame 0, flow mask only): the issue's
// goal (0.5 cm) is the bound; measured stop-and-go 0.13 cm, group 0.18 cm, towards the camera
// 0.17 cm (150 frames, seed 1); 6 people crossing, seed 2 (the start in a crowd: the camera's
// motion is not found on frame 1) 0.12 cm, 8.84 cm before unknown_motion_is_dynamic.
constexpr double DYPHO_HARD_CASE_ATE_BOUND_M = 0.005;

/// A still camera's 150 frames with people in view from frame 0 (dypho_synth `args`, `seed`),
/// generated into testOut()/`name`; returns its folder ("" when generation failed).
std::string stillCameraCrowd(const std::string& name, const std::string& args, int seed) {
  const std::string dir = testOut() + "/" + name;
  const std::string cmd = std::string("rm -rf '") + dir + "' && '" + DYPHO_SYNTH + "' --out '" + dir +
                          "' --frames 150 --motion static --people-in-view " + args + " --seed " +
                          std::to_string(seed) + " --no-bag > /dev/null";
  return std::system(cmd.c_str()) == 0 ? dir : std::string();
}

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

/// One run of an option's comparison (expectLowerAte).
struct RunVariant {
  const char* name;    ///< run folder suffix and what the printed line calls it
  std::string config;  ///< config YAML ("" = the defaults)
};

/// `config` with the saved trajectory's smoothing off (trajectory_smoothing_s: 0), added to its
/// tracking: block or as one.
std::string withRawTrajectory(const std::string& config) {
  const std::string block = "tracking:\n", key = "  trajectory_smoothing_s: 0\n";
  const std::size_t at = config.find(block);
  if (at == std::string::npos) return config + block + key;
  return std::string(config).insert(at + block.size(), key);
}

/// One option's effect on `data`: runs it with `with.config` and with `without.config` (config
/// YAML, "" = the defaults), each into the run folder data + "_run_" + its name, prints both ATE
/// RMSEs of the unsmoothed trajectory after `label`, and expects the first at least `min_gain_m`
/// lower.
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

}  // namespace DYPHO_UNITY_ID
