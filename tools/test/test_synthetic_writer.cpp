// Unit tests of writeSyntheticDataset: the TUM-layout folder matches the rendered frames and is
// readable by TumDataset (when dypho_tools is built).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "dypho/tools/synthetic_writer.h"
#ifdef DYPHO_HAVE_TOOLS_IO
#include "dypho/tools/camera_config.h"
#include "dypho/common/trajectory_io.h"
#include "dypho/tools/tum_dataset.h"
#endif

namespace fs = std::filesystem;
using dypho::tools::SynthOptions;

namespace DYPHO_UNITY_ID {

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("dypho_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::vector<std::string>> dataLines(const fs::path& p) {
  std::vector<std::vector<std::string>> out;
  std::istringstream in(readText(p));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::vector<std::string> words;
    for (std::string w; ls >> w;) words.push_back(w);
    out.push_back(words);
  }
  return out;
}

SynthOptions smallOptions() {
  SynthOptions o;
  o.frames = 6;
  o.people = 2;
  o.seed = 3;
  return o;
}

TEST(SyntheticWriter, FolderMatchesTheRenderedFrames) {
  const SynthOptions o = smallOptions();
  const fs::path dir = freshDir("synth_writer");
  dypho::tools::SynthWriteOptions w;
  w.command_line = "dypho_synth --out test --frames 6";
  int callbacks = 0;
  w.on_frame = [&](const dypho::tools::SynthFrame&) { ++callbacks; };
  const auto summary = dypho::tools::writeSyntheticDataset(o, dir.string(), w);
  EXPECT_EQ(summary.frames, o.frames);
  EXPECT_EQ(callbacks, o.frames);

  const auto rgb = dataLines(dir / "rgb.txt"), depth = dataLines(dir / "depth.txt"), mask = dataLines(dir / "mask.txt"),
             gt = dataLines(dir / "groundtruth.txt");
  ASSERT_EQ(rgb.size(), 6u);
  ASSERT_EQ(depth.size(), 6u);
  ASSERT_EQ(mask.size(), 6u);
  ASSERT_EQ(gt.size(), 6u);
  const dypho::tools::SyntheticScene scene(o);
  for (int i = 0; i < o.frames; i += 5) {
    const auto f = scene.render(i);
    EXPECT_NEAR(std::stod(rgb[i][0]), scene.stampSeconds(i), 1e-6);
    const cv::Mat bgr = cv::imread((dir / rgb[i][1]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(bgr.type(), CV_8UC3);
    EXPECT_EQ(cv::norm(bgr, f.frame.bgr, cv::NORM_INF), 0.0);  // PNG is lossless
    const cv::Mat raw = cv::imread((dir / depth[i][1]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(raw.type(), CV_16UC1);
    cv::Mat depth_m;
    raw.convertTo(depth_m, CV_32F, 1.0 / 5000.0);
    // The renderer already quantises to 1/5000 m, so only float rounding remains (< 1e-5 m).
    EXPECT_LT(cv::norm(depth_m, f.frame.depth_m, cv::NORM_INF), 1e-5);
    const cv::Mat m = cv::imread((dir / mask[i][1]).string(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(cv::norm(m, f.mask_gt, cv::NORM_INF), 0.0);
    ASSERT_EQ(gt[i].size(), 8u);
    const Eigen::Vector3d t(std::stod(gt[i][1]), std::stod(gt[i][2]), std::stod(gt[i][3]));
    const Eigen::Quaterniond q(std::stod(gt[i][7]), std::stod(gt[i][4]), std::stod(gt[i][5]), std::stod(gt[i][6]));
    EXPECT_LT((t - f.T_world_camera.translation()).norm(), 1e-6);
    EXPECT_LT(Eigen::AngleAxisd(q.toRotationMatrix().transpose() * f.T_world_camera.linear()).angle(), 1e-6);
  }
  EXPECT_NE(readText(dir / "camera.yaml").find("name: synthetic"), std::string::npos);
  EXPECT_NE(readText(dir / "README.txt").find(w.command_line), std::string::npos);
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << "left over: " << e.path();
  }
  fs::remove_all(dir);
}

#ifdef DYPHO_HAVE_TOOLS_IO
TEST(SyntheticWriter, TumDatasetReadsTheFolderBack) {
  const SynthOptions o = smallOptions();
  const fs::path dir = freshDir("synth_tum");
  dypho::tools::writeSyntheticDataset(o, dir.string());
  const auto detected = dypho::tools::detectCameraName(dir.string());
  ASSERT_TRUE(detected.has_value());
  const auto cfg =
      dypho::tools::loadCameraConfig(dypho::tools::resolveCameraConfig(*detected, dypho::tools::defaultConfigDir()));
  EXPECT_EQ(cfg.name, "synthetic");
  EXPECT_EQ(cfg.camera.width, o.camera.width);
  EXPECT_DOUBLE_EQ(cfg.camera.fx, o.camera.fx);
  EXPECT_DOUBLE_EQ(cfg.camera.cy, o.camera.cy);
  EXPECT_DOUBLE_EQ(cfg.depth_scale, 5000.0);
  EXPECT_DOUBLE_EQ(cfg.rolling_shutter_readout_ms, 0.0);  // a global shutter unless asked for
  const auto ds = dypho::tools::TumDataset::open(dir.string(), cfg);
  ASSERT_EQ(ds.size(), static_cast<std::size_t>(o.frames));
  ASSERT_EQ(ds.groundtruth().size(), static_cast<std::size_t>(o.frames));
  const dypho::tools::SyntheticScene scene(o);
  for (std::size_t i = 0; i < ds.size(); i += 2) {
    const auto f = scene.render(static_cast<int>(i));
    const dypho::RgbdFrame loaded = ds.load(i);
    EXPECT_EQ(loaded.stamp_ns, f.frame.stamp_ns);
    EXPECT_EQ(cv::norm(loaded.bgr, f.frame.bgr, cv::NORM_INF), 0.0);
    EXPECT_LT(cv::norm(loaded.depth_m, f.frame.depth_m, cv::NORM_INF), 1e-5);
    EXPECT_TRUE(ds.groundtruth()[i].T_world_camera.isApprox(f.T_world_camera, 1e-6));
  }
  fs::remove_all(dir);
}
#endif

TEST(SyntheticWriter, CameraFileCarriesTheRollingShutter) {
  const std::string yaml = dypho::tools::synthCameraYaml(smallOptions().camera, 5000.0, 30.0);
  EXPECT_NE(yaml.find("rolling_shutter_readout_ms: 30\n"), std::string::npos) << yaml;
  EXPECT_EQ(dypho::tools::synthCameraYaml(smallOptions().camera).find("rolling_shutter"), std::string::npos);
}

TEST(SyntheticWriter, ReadmeRecordsThePeopleOptions) {
  SynthOptions o = smallOptions();
  o.frames = 2;
  o.people = 3;
  o.walk = dypho::tools::SynthWalk::kTowards;
  o.people_in_view_at_start = true;
  o.people_distance_m = 1.2;
  o.camera.width = 160;
  o.camera.height = 120;
  o.camera.fx = o.camera.fy = 131.25;
  o.camera.cx = 79.5;
  o.camera.cy = 59.5;
  const fs::path dir = freshDir("synth_readme");
  const auto summary = dypho::tools::writeSyntheticDataset(o, dir.string());
  EXPECT_GT(summary.mean_dynamic_fraction, 0.0) << "people in view from frame 0";
  const std::string readme = readText(dir / "README.txt");
  for (const char* part : {"people=3 walk=towards people_in_view_at_start=true people_distance_m=1.2",
                           "People: walk towards", "all inside the image at frame 0", "from 3.2 m to 1.2 m"}) {
    EXPECT_NE(readme.find(part), std::string::npos) << "'" << part << "' missing in:\n" << readme;
  }
  fs::remove_all(dir);
}

TEST(SyntheticWriter, UnwritableFolderIsAClearError) {
  const fs::path file = freshDir("synth_file");
  { std::ofstream(file.string()) << "x"; }
  try {
    dypho::tools::writeSyntheticDataset(smallOptions(), (file / "sub").string());
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot create"), std::string::npos) << e.what();
  }
  fs::remove(file);
  SynthOptions bad = smallOptions();
  bad.people = 9;
  EXPECT_THROW(dypho::tools::writeSyntheticDataset(bad, freshDir("synth_bad").string()), std::runtime_error);
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
