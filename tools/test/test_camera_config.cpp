// Camera YAML loading, name resolution and dataset camera detection.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tools/camera_config.h"

namespace fs = std::filesystem;
using namespace dypho::tools;

namespace DYPHO_UNITY_ID {

const std::string kConfigDir = std::string(DYPHO_SOURCE_DIR) + "/config";
const std::string kDataDir = std::string(DYPHO_SHARED_DIR) + "/data";

fs::path makeTempDir(const std::string& name) {
  std::string tmpl = (fs::temp_directory_path() / ("dypho_cam_" + name + "_XXXXXX")).string();
  if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  return tmpl;
}

void writeText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

const std::string kValidYaml =
    "name: test_cam\nwidth: 320\nheight: 240\nfx: 300.5\nfy: 301.5\ncx: 160.0\ncy: 120.0\n"
    "distortion: [0.1, -0.2, 0.001, 0.002, 0.3]\ndepth_scale: 1000.0\n";

/// Expects loadCameraConfig(file with `yaml`) to throw with every string of `needles` in the message.
void expectLoadError(const std::string& yaml, const std::vector<std::string>& needles) {
  const fs::path dir = makeTempDir("err");
  const fs::path file = dir / "cam.yaml";
  writeText(file, yaml);
  try {
    loadCameraConfig(file.string());
    ADD_FAILURE() << "no error for:\n" << yaml;
  } catch (const std::runtime_error& e) {
    for (const auto& n : needles) {
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << "'" << n << "' not in: " << e.what();
    }
  }
  fs::remove_all(dir);
}

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  if (pos == std::string::npos) throw std::logic_error("test bug: '" + from + "' not found");
  return s.replace(pos, from.size(), to);
}

TEST(CameraConfig, ParsesEveryField) {
  const fs::path dir = makeTempDir("ok");
  writeText(dir / "cam.yaml", kValidYaml);
  const CameraConfig c = loadCameraConfig((dir / "cam.yaml").string());
  EXPECT_EQ(c.name, "test_cam");
  EXPECT_EQ(c.camera.width, 320);
  EXPECT_EQ(c.camera.height, 240);
  EXPECT_DOUBLE_EQ(c.camera.fx, 300.5);
  EXPECT_DOUBLE_EQ(c.camera.fy, 301.5);
  EXPECT_DOUBLE_EQ(c.camera.cx, 160.0);
  EXPECT_DOUBLE_EQ(c.camera.cy, 120.0);
  EXPECT_DOUBLE_EQ(c.camera.distortion[0], 0.1);
  EXPECT_DOUBLE_EQ(c.camera.distortion[1], -0.2);
  EXPECT_DOUBLE_EQ(c.camera.distortion[2], 0.001);
  EXPECT_DOUBLE_EQ(c.camera.distortion[3], 0.002);
  EXPECT_DOUBLE_EQ(c.camera.distortion[4], 0.3);
  EXPECT_DOUBLE_EQ(c.depth_scale, 1000.0);
  EXPECT_DOUBLE_EQ(c.rolling_shutter_readout_ms, 0.0);  // optional key left out: global shutter
  writeText(dir / "rolling.yaml", kValidYaml + "rolling_shutter_readout_ms: 22.5\n");
  EXPECT_DOUBLE_EQ(loadCameraConfig((dir / "rolling.yaml").string()).rolling_shutter_readout_ms, 22.5);
  fs::remove_all(dir);
}

TEST(CameraConfig, EveryShippedYamlLoads) {
  const auto names = listCameraNames(kConfigDir);
  for (const char* expected : {"bonn", "tum_fr1", "tum_fr2", "tum_fr3"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  for (const auto& name : names) {
    SCOPED_TRACE(name);
    const CameraConfig c = loadCameraConfig(resolveCameraConfig(name, kConfigDir));
    EXPECT_EQ(c.name, name);  // the name key must match the file name used to look it up
    EXPECT_TRUE(c.camera.valid());
    EXPECT_EQ(c.camera.width, 640);
    EXPECT_EQ(c.camera.height, 480);
    EXPECT_DOUBLE_EQ(c.depth_scale, 5000.0);
    // Principal point near the image centre (within 10 % of the size) for all these cameras.
    EXPECT_NEAR(c.camera.cx, 320.0, 64.0);
    EXPECT_NEAR(c.camera.cy, 240.0, 48.0);
  }
}

TEST(CameraConfig, PublishedCalibrations) {
  // Values from the TUM / Bonn dataset pages (also in the shared data's SOURCE.txt files).
  const CameraConfig fr1 = loadCameraConfig(resolveCameraConfig("tum_fr1", kConfigDir));
  EXPECT_DOUBLE_EQ(fr1.camera.fx, 517.306408);
  EXPECT_DOUBLE_EQ(fr1.camera.cy, 255.313989);
  EXPECT_DOUBLE_EQ(fr1.camera.distortion[4], 1.163314);
  EXPECT_TRUE(fr1.camera.distorted());
  const CameraConfig fr3 = loadCameraConfig(resolveCameraConfig("tum_fr3", kConfigDir));
  EXPECT_DOUBLE_EQ(fr3.camera.fy, 539.2);
  EXPECT_FALSE(fr3.camera.distorted());
  const CameraConfig bonn = loadCameraConfig(resolveCameraConfig("bonn", kConfigDir));
  EXPECT_DOUBLE_EQ(bonn.camera.fx, 542.822841);
  EXPECT_DOUBLE_EQ(bonn.camera.cx, 315.593520);
  EXPECT_FALSE(bonn.camera.distorted());
  // The Kinect-class cameras' rolling shutter (measured on fr1 and Bonn, docs/journal).
  EXPECT_DOUBLE_EQ(fr1.rolling_shutter_readout_ms, 30.0);
  EXPECT_DOUBLE_EQ(bonn.rolling_shutter_readout_ms, 30.0);
}

TEST(CameraConfig, Errors) {
  expectLoadError(kValidYaml + "baseline: 0.1\n", {"unknown key", "baseline", "cam.yaml"});
  expectLoadError(replaced(kValidYaml, "fy: 301.5\n", ""), {"missing key", "'fy'"});
  expectLoadError(replaced(kValidYaml, "depth_scale: 1000.0\n", ""), {"missing key", "depth_scale"});
  expectLoadError(replaced(kValidYaml, "fx: 300.5", "fx: abc"), {"fx", "abc"});
  expectLoadError(replaced(kValidYaml, "fx: 300.5", "fx: -1"), {"fx", "> 0"});
  expectLoadError(replaced(kValidYaml, "width: 320", "width: 320.5"), {"width"});
  expectLoadError(replaced(kValidYaml, "[0.1, -0.2, 0.001, 0.002, 0.3]", "[0.1, 0.2]"), {"distortion", "5"});
  expectLoadError(kValidYaml + "rolling_shutter_readout_ms: -5\n", {"rolling_shutter_readout_ms", "[0, 100]"});
  expectLoadError(kValidYaml + "rolling_shutter_readout_ms: abc\n", {"rolling_shutter_readout_ms"});
  expectLoadError("- 1\n- 2\n", {"map"});
  expectLoadError("name: [unclosed\n", {"not valid YAML"});
  EXPECT_THROW(loadCameraConfig("/nonexistent/cam.yaml"), std::runtime_error);
}

TEST(CameraConfig, Resolve) {
  EXPECT_EQ(resolveCameraConfig("tum_fr2", kConfigDir), kConfigDir + "/cameras/tum_fr2.yaml");
  const fs::path dir = makeTempDir("res");
  writeText(dir / "mine.yaml", kValidYaml);
  EXPECT_EQ(resolveCameraConfig((dir / "mine.yaml").string(), kConfigDir), (dir / "mine.yaml").string());
  try {
    resolveCameraConfig("tum_fr9", kConfigDir);
    ADD_FAILURE() << "unknown camera accepted";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("tum_fr9"), std::string::npos) << msg;
    EXPECT_NE(msg.find("tum_fr1"), std::string::npos) << "known names not listed: " << msg;
    EXPECT_NE(msg.find("bonn"), std::string::npos) << "known names not listed: " << msg;
  }
  fs::remove_all(dir);
}

TEST(CameraConfig, DefaultConfigDir) {
  const char* old = std::getenv("DYPHO_CONFIG_DIR");
  const std::string saved = old ? old : "";
  ::setenv("DYPHO_CONFIG_DIR", "/some/where", 1);
  EXPECT_EQ(defaultConfigDir(), "/some/where");
  ::unsetenv("DYPHO_CONFIG_DIR");
  // Without the variable the source tree's config/ (which exists here) is used.
  EXPECT_TRUE(fs::equivalent(defaultConfigDir(), kConfigDir)) << defaultConfigDir();
  if (old) ::setenv("DYPHO_CONFIG_DIR", saved.c_str(), 1);
}

TEST(CameraConfig, DetectFromHeaderFolderNameAndFile) {
  const fs::path dir = makeTempDir("plain");  // name contains no camera hint
  EXPECT_EQ(detectCameraName(dir.string()), std::nullopt);
  writeText(dir / "rgb.txt", "# color images\n# file: 'rgbd_dataset_freiburg2_desk.bag'\n# timestamp filename\n");
  EXPECT_EQ(detectCameraName(dir.string()), std::optional<std::string>("tum_fr2"));
  writeText(dir / "camera.yaml", kValidYaml);  // an explicit camera file wins
  EXPECT_EQ(detectCameraName(dir.string()), std::optional<std::string>((dir / "camera.yaml").string()));
  fs::remove_all(dir);

  const fs::path parent = makeTempDir("parent");
  for (const auto& [folder, expected] :
       std::vector<std::pair<std::string, std::string>>{{"rgbd_dataset_freiburg3_walking_xyz", "tum_fr3"},
                                                        {"fr1_desk", "tum_fr1"},
                                                        {"my_fr2", "tum_fr2"},
                                                        {"rgbd_bonn_balloon", "bonn"},
                                                        {"frame12", ""},
                                                        {"fr10", ""}}) {
    fs::create_directory(parent / folder);
    const auto got = detectCameraName((parent / folder).string());
    if (expected.empty()) {
      EXPECT_EQ(got, std::nullopt) << folder;
    } else {
      EXPECT_EQ(got, std::optional<std::string>(expected)) << folder;
    }
  }
  fs::remove_all(parent);
}

TEST(CameraConfig, DetectSharedDatasets) {
  if (!fs::is_directory(kDataDir)) {
    std::printf("skipping: shared data folder %s is absent\n", kDataDir.c_str());
    GTEST_SKIP() << "shared data absent: " << kDataDir;
  }
  // fr1 via the "# file: 'rgbd_dataset_freiburg1_rpy.bag'" header, Bonn via the folder name.
  EXPECT_EQ(detectCameraName(kDataDir + "/tum_fr1_rpy_first150"), std::optional<std::string>("tum_fr1"));
  EXPECT_EQ(detectCameraName(kDataDir + "/rgbd_bonn_crowd_frames200to399"), std::optional<std::string>("bonn"));
  // The fr1 folder name also says "fr1": copy its rgb.txt into a neutral folder to check the header rule alone.
  const fs::path dir = makeTempDir("hdr");
  fs::copy_file(kDataDir + "/tum_fr1_rpy_first150/rgb.txt", dir / "rgb.txt");
  EXPECT_EQ(detectCameraName(dir.string()), std::optional<std::string>("tum_fr1"));
  fs::remove_all(dir);
}  // namespace DYPHO_UNITY_ID
}  // namespace DYPHO_UNITY_ID
