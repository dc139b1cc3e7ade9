#pragma once
/// \file dataset_run.h
/// What the whole-system dataset tests share (test_datasets.cpp, test_still_camera_crowd.cpp):
/// where runs write, the shared data, running the installed dypho_run_dataset, a run's ATE.
/// Needs the target's compile definitions DYPHO_RUN_DATASET, DYPHO_TEST_OUT and DYPHO_SHARED_DIR.

#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "dypho/common/trajectory_io.h"
#include "dypho/tools/evaluation.h"

namespace dypho {
namespace dataset_run {

/// Where the runs write: DYPHO_TEST_OUT, or its shard<i> subfolder when gtest runs this process as
/// one of several shards side by side (scripts/run_gtest.sh --shards): every run, and every
/// generated sequence, then belongs to one process.
inline std::string testOut() {
  const char* index = std::getenv("GTEST_SHARD_INDEX");
  const char* total = std::getenv("GTEST_TOTAL_SHARDS");
  if (index == nullptr || total == nullptr || std::atoi(total) <= 1) return DYPHO_TEST_OUT;
  return std::string(DYPHO_TEST_OUT) + "/shard" + index;
}

inline bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

/// ../shared beside the repository, or DYPHO_SHARED_DIR from the environment.
inline std::string sharedDir() {
  const char* env = std::getenv("DYPHO_SHARED_DIR");
  return env != nullptr ? env : DYPHO_SHARED_DIR;
}

/// The trajectory tests run mask and tracking only (--no-map): with R_d off (the default) the map
/// does not feed back into the trajectory (SyntheticDefaultInput checks that the trajectory is the
/// same with and without it), and training the map took most of each run's time.
inline constexpr const char* kTrajectoryOnly = "--no-map";

/// Runs dypho_run_dataset and returns its exit code; output goes to <out>/log.txt.
inline int runDataset(const std::string& dataset, const std::string& out, const std::string& extra = "") {
  const std::string cmd = std::string("mkdir -p '") + out + "' && '" + DYPHO_RUN_DATASET + "' --dataset '" + dataset +
                          "' --out '" + out + "' --quiet " + extra + " > '" + out + "/log.txt' 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream log(out + "/log.txt");
  std::cout << log.rdbuf() << std::endl;
  return WEXITSTATUS(status);
}

inline std::string readText(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// ATE RMSE [m] of the run's trajectory.txt in `out` against `gt`.
inline double ateOf(const std::string& out, const std::vector<StampedPose>& gt) {
  const auto est = readTumTrajectory(out + "/trajectory.txt");
  return tools::computeAte(est, gt).rmse_m;
}

}  // namespace dataset_run
}  // namespace dypho
