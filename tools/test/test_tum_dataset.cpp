// TUM-layout dataset reader: association rule, error messages, real TUM and Bonn folders.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "dypho/tools/tum_dataset.h"

namespace fs = std::filesystem;
using namespace dypho::tools;

namespace DYPHO_UNITY_ID {

const std::string kDataDir = std::string(DYPHO_SHARED_DIR) + "/data";
const std::string kConfigDir = std::string(DYPHO_SOURCE_DIR) + "/config";

fs::path makeTempDir(const std::string& name) {
  std::string tmpl = (fs::temp_directory_path() / ("dypho_ds_" + name + "_XXXXXX")).string();
  if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  return tmpl;
}

void writeText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

CameraConfig smallCamera() {
  CameraConfig c;
  c.name = "small";
  c.camera.width = 8;
  c.camera.height = 6;
  c.camera.fx = c.camera.fy = 10.0;
  c.camera.cx = 3.5;
  c.camera.cy = 2.5;
  c.depth_scale = 5000.0;
  return c;
}

/// A 3-frame synthetic TUM folder (8x6 images) with a ground truth file.
fs::path makeSyntheticDataset(const std::string& name) {
  const fs::path dir = makeTempDir(name);
  fs::create_directory(dir / "rgb");
  fs::create_directory(dir / "depth");
  std::string rgb = "# color images\n# timestamp filename\n";
  std::string depth = "# depth maps\n# timestamp filename\n";
  const char* rgb_stamps[] = {"100.000000", "100.033333", "100.066667"};
  const char* depth_stamps[] = {"100.001000", "100.034000", "100.065000"};
  for (int i = 0; i < 3; ++i) {
    cv::Mat bgr(6, 8, CV_8UC3, cv::Scalar(10 * i, 20, 30));
    cv::Mat raw(6, 8, CV_16UC1, cv::Scalar(5000 + 1000 * i));
    raw.at<std::uint16_t>(0, 0) = 0;  // invalid depth must stay 0
    cv::imwrite((dir / "rgb" / (std::string(rgb_stamps[i]) + ".png")).string(), bgr);
    cv::imwrite((dir / "depth" / (std::string(depth_stamps[i]) + ".png")).string(), raw);
    rgb += std::string(rgb_stamps[i]) + " rgb/" + rgb_stamps[i] + ".png\n";
    depth += std::string(depth_stamps[i]) + " depth/" + depth_stamps[i] + ".png\n";
  }
  writeText(dir / "rgb.txt", rgb);
  writeText(dir / "depth.txt", depth);
  writeText(dir / "groundtruth.txt", "# gt\n100.0 1 2 3 0 0 0 1\n100.05 1 2 4 0 0 0 1\n");
  return dir;
}

/// Runs `fn`, expects a DatasetError whose message contains `needle`.
template <typename Fn>
void expectDatasetError(Fn fn, const std::string& needle) {
  try {
    fn();
    ADD_FAILURE() << "no DatasetError (expected one mentioning '" << needle << "')";
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << "'" << needle << "' not in: " << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type: " << e.what();
  }
}

/// Straightforward re-implementation of TUM associate.py (all pairs, sort, greedy) as reference.
std::vector<std::pair<std::size_t, std::size_t>> referenceAssociate(const std::vector<double>& a,
                                                                    const std::vector<double>& b, double max_dt) {
  std::vector<std::tuple<double, double, double, std::size_t, std::size_t>> cand;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j)
      if (std::abs(a[i] - b[j]) < max_dt) cand.emplace_back(std::abs(a[i] - b[j]), a[i], b[j], i, j);
  std::sort(cand.begin(), cand.end());
  std::vector<bool> ua(a.size()), ub(b.size());
  std::vector<std::pair<std::size_t, std::size_t>> m;
  for (const auto& c : cand) {
    const std::size_t i = std::get<3>(c), j = std::get<4>(c);
    if (ua[i] || ub[j]) continue;
    ua[i] = ub[j] = true;
    m.emplace_back(i, j);
  }
  std::sort(m.begin(), m.end(), [&a](const auto& x, const auto& y) { return a[x.first] < a[y.first]; });
  return m;
}

bool sharedDataPresent() {
  if (fs::is_directory(kDataDir)) return true;
  std::printf("skipping: shared data folder %s is absent (set DYPHO_SHARED_DIR at configure time)\n", kDataDir.c_str());
  return false;
}

TEST(ParseSeconds, ExactNanoseconds) {
  dypho::Timestamp ns = 0;
  ASSERT_TRUE(parseSecondsToNs("1305031229.528748", &ns));
  EXPECT_EQ(ns, 1305031229528748000LL);
  ASSERT_TRUE(parseSecondsToNs("1548339826.57814", &ns));
  EXPECT_EQ(ns, 1548339826578140000LL);
  ASSERT_TRUE(parseSecondsToNs("0.0000000015", &ns));  // rounds on the 10th decimal
  EXPECT_EQ(ns, 2);
  ASSERT_TRUE(parseSecondsToNs("12", &ns));
  EXPECT_EQ(ns, 12000000000LL);
  EXPECT_FALSE(parseSecondsToNs("1.2e3", &ns));
  EXPECT_FALSE(parseSecondsToNs("abc", &ns));
  EXPECT_FALSE(parseSecondsToNs("", &ns));
  // Beyond int64 nanoseconds (found by fuzz_tum_lists: used to overflow): rejected.
  EXPECT_FALSE(parseSecondsToNs("9600000000.000001", &ns));
  ASSERT_TRUE(parseSecondsToNs("9223372035.5", &ns));
  EXPECT_EQ(ns, 9223372035500000000LL);
}

TEST(Associate, GreedyBySmallestDifference) {
  // Both rgb stamps prefer depth 1.012 but only the closer one (1.015, diff 0.003) gets it; 1.000
  // then takes its second choice 0.995 (diff 0.005). Per-rgb nearest would give 1.000 -> 1.012.
  const std::vector<double> rgb = {1.000, 1.015};
  const std::vector<double> depth = {1.012, 0.995};
  const auto m = associateStamps(rgb, depth, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(std::size_t{0}, std::size_t{1}));
  EXPECT_EQ(m[1], std::make_pair(std::size_t{1}, std::size_t{0}));
  // One depth shared by two rgb frames: only one of them is associated (each depth used once).
  const auto m2 = associateStamps({2.000, 2.010}, {2.008}, 0.02);
  ASSERT_EQ(m2.size(), 1u);
  EXPECT_EQ(m2[0].first, 1u);
  // Outside the window: no pair.
  EXPECT_TRUE(associateStamps({3.0}, {3.025}, 0.02).empty());
}

TEST(Associate, MatchesReferenceOnRandomStamps) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> jitter(-0.02, 0.02);
  std::bernoulli_distribution drop(0.1);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> rgb, depth;
    for (int i = 0; i < 200; ++i) {
      if (!drop(rng)) rgb.push_back(1000.0 + i / 30.0 + jitter(rng));
      if (!drop(rng)) depth.push_back(1000.0 + i / 30.0 + jitter(rng));
    }
    std::shuffle(depth.begin(), depth.end(), rng);  // the input order must not matter
    EXPECT_EQ(associateStamps(rgb, depth, 0.02), referenceAssociate(rgb, depth, 0.02)) << "trial " << trial;
  }
}

TEST(TumDataset, SyntheticLoad) {
  const fs::path dir = makeSyntheticDataset("ok");
  const TumDataset ds = TumDataset::open(dir.string(), smallCamera());
  ASSERT_EQ(ds.size(), 3u);
  EXPECT_EQ(ds.numRgbLines(), 3u);
  EXPECT_EQ(ds.groundtruth().size(), 2u);
  EXPECT_EQ(ds.directory(), dir.string());
  EXPECT_EQ(ds.camera().name, "small");
  EXPECT_EQ(ds.entry(1).stamp_ns, 100033333000LL);
  EXPECT_TRUE(fs::path(ds.entry(1).rgb_path).is_absolute());
  EXPECT_EQ(fs::path(ds.entry(1).depth_path).filename(), "100.034000.png");
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const dypho::RgbdFrame f = ds.load(i);
    EXPECT_EQ(f.stamp_ns, ds.entry(i).stamp_ns);
    EXPECT_EQ(f.bgr.type(), CV_8UC3);
    EXPECT_EQ(f.bgr.at<cv::Vec3b>(2, 2), cv::Vec3b(10 * i, 20, 30));  // B, G, R order kept
    EXPECT_EQ(f.depth_m.type(), CV_32FC1);
    EXPECT_EQ(f.depth_m.at<float>(0, 0), 0.0f);
    // raw / 5000 in float: exact to float rounding (relative 6e-8).
    EXPECT_NEAR(f.depth_m.at<float>(3, 4), (5000.0 + 1000.0 * i) / 5000.0, 1e-6);
    EXPECT_EQ(f.camera.fx, 10.0);
  }
  EXPECT_THROW(ds.entry(3), std::out_of_range);
  fs::remove_all(dir);
}

TEST(TumDataset, ErrorsNameTheFile) {
  const CameraConfig cam = smallCamera();
  {
    const fs::path dir = makeSyntheticDataset("norgb");
    fs::remove(dir / "rgb.txt");
    expectDatasetError([&] { TumDataset::open(dir.string(), cam); }, "rgb.txt");
    fs::remove_all(dir);
  }
  {
    const fs::path dir = makeSyntheticDataset("badline");
    std::ofstream(dir / "depth.txt", std::ios::app) << "100.1\n";  // line 6: no file name
    // A malformed line is skipped and named; the dataset still opens with the other lines.
    const TumDataset ds = TumDataset::open(dir.string(), cam);
    ASSERT_EQ(ds.skippedLines().size(), 1u);
    EXPECT_NE(ds.skippedLines()[0].find("depth.txt:6"), std::string::npos) << ds.skippedLines()[0];
    EXPECT_GT(ds.size(), 0u);
    EXPECT_THROW(readStampedFileList((dir / "depth.txt").string()), DatasetError);  // strict without a list
    fs::remove_all(dir);
  }
  {
    const fs::path dir = makeSyntheticDataset("badgt");
    std::ofstream(dir / "groundtruth.txt", std::ios::app) << "100.1 1 2\n";
    expectDatasetError([&] { TumDataset::open(dir.string(), cam); }, "groundtruth.txt:4");
    fs::remove_all(dir);
  }
  {
    const fs::path dir = makeSyntheticDataset("nopng");
    fs::remove(dir / "rgb" / "100.033333.png");
    const TumDataset ds = TumDataset::open(dir.string(), cam);
    expectDatasetError([&] { ds.load(1); }, "100.033333.png");
    EXPECT_NO_THROW(ds.load(0));
    fs::remove_all(dir);
  }
  {
    const fs::path dir = makeSyntheticDataset("depth8");
    cv::imwrite((dir / "depth" / "100.065000.png").string(), cv::Mat(6, 8, CV_8UC1, cv::Scalar(3)));
    const TumDataset ds = TumDataset::open(dir.string(), cam);
    expectDatasetError([&] { ds.load(2); }, "100.065000.png");
    expectDatasetError([&] { ds.load(2); }, "16UC1");
    fs::remove_all(dir);
  }
  {
    const fs::path dir = makeSyntheticDataset("size");
    cv::imwrite((dir / "rgb" / "100.000000.png").string(), cv::Mat(7, 8, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite((dir / "depth" / "100.034000.png").string(), cv::Mat(6, 9, CV_16UC1, cv::Scalar(1)));
    const TumDataset ds = TumDataset::open(dir.string(), cam);
    expectDatasetError([&] { ds.load(0); }, "100.000000.png");
    expectDatasetError([&] { ds.load(1); }, "100.034000.png");
    fs::remove_all(dir);
  }
  {
    const fs::path dir = makeSyntheticDataset("noassoc");
    writeText(dir / "depth.txt", "200.0 depth/100.001000.png\n");
    expectDatasetError([&] { TumDataset::open(dir.string(), cam); }, "max_dt_s");
    fs::remove_all(dir);
  }
  expectDatasetError([&] { TumDataset::open("/nonexistent/dypho_ds", cam); }, "/nonexistent/dypho_ds");
}

TEST(TumDataset, RealTumFr1) {
  if (!sharedDataPresent()) GTEST_SKIP() << "shared data absent";
  const CameraConfig cam = loadCameraConfig(resolveCameraConfig("tum_fr1", kConfigDir));
  const TumDataset ds = TumDataset::open(kDataDir + "/tum_fr1_rpy_first150", cam);
  // SOURCE.txt: 150 rgb frames, each with a depth frame within 0.02 s; 597 ground-truth poses.
  EXPECT_EQ(ds.numRgbLines(), 150u);
  ASSERT_EQ(ds.size(), 150u);
  EXPECT_EQ(ds.groundtruth().size(), 597u);
  EXPECT_EQ(ds.entry(0).stamp_ns, 1305031229528748000LL);
  for (std::size_t i = 0; i < ds.size(); ++i) {
    EXPECT_LT(std::abs(ds.entry(i).stamp_s - ds.entry(i).depth_stamp_s), 0.02);
    if (i > 0) {
      EXPECT_GT(ds.entry(i).stamp_s, ds.entry(i - 1).stamp_s);
    }
  }
  for (std::size_t i : {std::size_t{0}, std::size_t{75}, std::size_t{149}}) {
    const dypho::RgbdFrame f = ds.load(i);
    EXPECT_EQ(f.bgr.size(), cv::Size(640, 480));
    EXPECT_DOUBLE_EQ(f.camera.fx, 517.306408);
    std::vector<float> valid;
    for (int v = 0; v < f.depth_m.rows; ++v)
      for (int u = 0; u < f.depth_m.cols; ++u)
        if (f.depth_m.at<float>(v, u) > 0.f) valid.push_back(f.depth_m.at<float>(v, u));
    // An office desk seen by a Kinect v1: most pixels valid, depths within the sensor's 0.4-8 m range.
    EXPECT_GT(valid.size(), 0.5 * 640 * 480) << "frame " << i;
    const auto [lo_it, hi_it] = std::minmax_element(valid.begin(), valid.end());
    const float lo = *lo_it, hi = *hi_it;  // copies: nth_element below reorders `valid`
    EXPECT_GE(lo, 0.3f);
    EXPECT_LE(hi, 10.0f);
    std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
    const float median = valid[valid.size() / 2];
    std::printf("fr1 frame %zu: %zu valid depth px, median %.3f m, range %.3f..%.3f m\n", i, valid.size(), median, lo,
                hi);
    EXPECT_GT(median, 0.5f);
    EXPECT_LT(median, 4.0f);
  }
}

TEST(TumDataset, RealBonnCrowd) {
  if (!sharedDataPresent()) GTEST_SKIP() << "shared data absent";
  const CameraConfig cam = loadCameraConfig(resolveCameraConfig("bonn", kConfigDir));
  const TumDataset ds = TumDataset::open(kDataDir + "/rgbd_bonn_crowd_frames200to399", cam);
  EXPECT_EQ(ds.numRgbLines(), 200u);
  // SOURCE.txt: one depth PNG is missing, so one rgb frame may lose its (shared) depth partner.
  EXPECT_GE(ds.size(), 199u);
  EXPECT_LE(ds.size(), 200u);
  EXPECT_EQ(ds.groundtruth().size(), 230u);
  std::printf("bonn crowd: %zu of %zu rgb frames associated\n", ds.size(), ds.numRgbLines());
  const dypho::RgbdFrame f = ds.load(0);
  std::vector<float> depths;
  for (int v = 0; v < f.depth_m.rows; ++v)
    for (int u = 0; u < f.depth_m.cols; ++u)
      if (f.depth_m.at<float>(v, u) > 0.f) depths.push_back(f.depth_m.at<float>(v, u));
  ASSERT_FALSE(depths.empty());
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  // SOURCE.txt: median raw values 12000-14500, i.e. 2.4-2.9 m; allow 2-3.5 m.
  EXPECT_GT(depths[depths.size() / 2], 2.0f);
  EXPECT_LT(depths[depths.size() / 2], 3.5f);
}  // namespace DYPHO_UNITY_ID
}  // namespace DYPHO_UNITY_ID
