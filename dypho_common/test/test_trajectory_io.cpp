// TUM trajectory reading/writing.
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "dypho/common/trajectory_io.h"

namespace fs = std::filesystem;
using namespace dypho;

namespace DYPHO_UNITY_ID {

fs::path makeTempDir(const std::string& name) {
  std::string tmpl = (fs::temp_directory_path() / ("dypho_traj_" + name + "_XXXXXX")).string();
  if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  return tmpl;
}

void writeText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

std::vector<StampedPose> randomPoses(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::vector<StampedPose> poses;
  for (int i = 0; i < n; ++i) {
    StampedPose p;
    p.stamp_s = 1305031229.528748 + i * 0.033333;
    p.T_world_camera.linear() =
        Eigen::Quaterniond(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    p.T_world_camera.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng));
    poses.push_back(p);
  }
  return poses;
}

std::string expectThrowMessage(const std::string& path) {
  try {
    readTumTrajectory(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error reading " << path;
  return "";
}

TEST(TrajectoryIo, RoundTripAndNoTemporaryLeft) {
  const fs::path dir = makeTempDir("rt");
  const std::string file = (dir / "traj.txt").string();
  const auto poses = randomPoses(50, 7);
  writeTumTrajectory(file, poses);
  const auto back = readTumTrajectory(file);
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    // Stamps are written with 6 decimals: at most 0.5 us rounding (+ double ulp at 1.3e9 s, 2.4e-7 s).
    EXPECT_NEAR(back[i].stamp_s, poses[i].stamp_s, 5e-7 + 2.5e-7);
    // 9 significant digits: relative error <= 5e-9; |t| <= 5*sqrt(3) m -> 5e-8 m bound.
    EXPECT_LT((back[i].T_world_camera.translation() - poses[i].T_world_camera.translation()).norm(), 5e-8);
    // Quaternion components <= 1 written with 9 significant digits -> ~1e-9 per component.
    EXPECT_LT((back[i].T_world_camera.linear() - poses[i].T_world_camera.linear()).norm(), 1e-8);
  }
  // Overwrite with a shorter trajectory: the rename replaces the old file wholesale.
  writeTumTrajectory(file, std::vector<StampedPose>(poses.begin(), poses.begin() + 3));
  EXPECT_EQ(readTumTrajectory(file).size(), 3u);
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    ++entries;
    EXPECT_EQ(e.path().filename(), "traj.txt") << "left over: " << e.path();
  }
  EXPECT_EQ(entries, 1);
  fs::remove_all(dir);
}

TEST(TrajectoryIo, CommentsBlankLinesCommasAndNormalisation) {
  const fs::path dir = makeTempDir("fmt");
  writeText(dir / "t.txt",
            "# ground truth trajectory\n\n"
            "1.5 1 2 3 0 0 0 2\n"  // unnormalised quaternion (qw=2) -> identity
            "   # indented comment\n"
            "2.5,4,5,6,0,0,0.7071067811865476,0.7071067811865476\r\n");  // commas, CRLF
  const auto poses = readTumTrajectory((dir / "t.txt").string());
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_DOUBLE_EQ(poses[0].stamp_s, 1.5);
  EXPECT_TRUE(poses[0].T_world_camera.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_TRUE(poses[1].T_world_camera.translation().isApprox(Eigen::Vector3d(4, 5, 6)));
  // 90 deg about z maps x to y.
  EXPECT_TRUE((poses[1].T_world_camera.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  fs::remove_all(dir);
}

TEST(TrajectoryIo, MalformedLinesNameFileAndLine) {
  const fs::path dir = makeTempDir("bad");
  const std::string ok = "1 0 0 0 0 0 0 1\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"# header\n" + ok + "2 0 0 0 0 0 1\n", ":3:"},  // 7 numbers
      {ok + ok + ok + "3 0 0 x 0 0 0 1\n", ":4:"},     // not a number
      {ok + "2 0 0 0 0 0 0 1 extra\n", ":2:"},         // trailing junk
      {"1 0 0 0 0 0 0 0\n", ":1:"},                    // zero quaternion
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const fs::path file = dir / ("bad" + std::to_string(k) + ".txt");
    writeText(file, cases[k].first);
    const std::string msg = expectThrowMessage(file.string());
    EXPECT_NE(msg.find(file.string() + cases[k].second), std::string::npos) << msg;
  }
  EXPECT_NE(expectThrowMessage((dir / "missing.txt").string()).find("missing.txt"), std::string::npos);
  fs::remove_all(dir);
}

TEST(TrajectoryIo, WriteIntoMissingFolderThrows) {
  EXPECT_THROW(writeTumTrajectory("/nonexistent_dir_dypho/traj.txt", randomPoses(2, 1)), std::runtime_error);
}  // namespace DYPHO_UNITY_ID
}  // namespace DYPHO_UNITY_ID
