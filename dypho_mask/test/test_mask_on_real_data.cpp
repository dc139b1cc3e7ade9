// Report-style checks of the flow mask on the real sequences in DYPHO_SHARED_DIR/data (skipped,
// loudly, when the data is absent). Prints masked fractions; asserts only coarse properties.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "dypho/mask/flow_motion_masker.h"

namespace dypho {
namespace mask {
namespace {

/// Image paths listed in a TUM-format rgb.txt ("timestamp path" lines, '#' comments).
std::vector<std::string> listImages(const std::string& folder) {
  std::vector<std::string> paths;
  std::ifstream in(folder + "/rgb.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    std::string stamp, path;
    if (s >> stamp >> path) paths.push_back(folder + "/" + path);
  }
  return paths;
}

struct RangeStats {
  double mean_fraction = 0.0;
  double max_fraction = 0.0;
  int degraded = 0;
  int frames = 0;
  double mean_total_ms = 0.0;
};

/// Runs the masker on images [first, last] (the first of them only primes the history).
RangeStats runRange(const std::vector<std::string>& paths, int first, int last) {
  FlowMotionMasker masker{FlowMaskOptions()};
  RangeStats st;
  for (int i = first; i <= last && i < static_cast<int>(paths.size()); ++i) {
    RgbdFrame f;
    f.bgr = cv::imread(paths[static_cast<std::size_t>(i)], cv::IMREAD_COLOR);
    EXPECT_FALSE(f.bgr.empty()) << "cannot read " << paths[static_cast<std::size_t>(i)];
    const FlowMaskResult r = masker.compute(f);
    if (i == first) continue;
    ++st.frames;
    st.degraded += r.degraded ? 1 : 0;
    st.mean_fraction += r.masked_fraction;
    st.max_fraction = std::max(st.max_fraction, r.masked_fraction);
    st.mean_total_ms += r.total_ms;
  }
  if (st.frames > 0) {
    st.mean_fraction /= st.frames;
    st.mean_total_ms /= st.frames;
  }
  return st;
}

void print(const char* label, const RangeStats& s) {
  std::printf("[ report ] %-44s frames %3d  masked mean %.4f max %.4f  degraded %d  %.2f ms\n", label, s.frames,
              s.mean_fraction, s.max_fraction, s.degraded, s.mean_total_ms);
}

TEST(FlowMaskRealData, BonnCrowdPeopleVersusEmptyRoom) {
  const std::string folder = std::string(DYPHO_SHARED_DIR) + "/data/rgbd_bonn_crowd_frames200to399";
  const auto paths = listImages(folder);
  if (paths.size() < 120) GTEST_SKIP() << "Bonn crowd data not found in " << folder;
  // SOURCE.txt says people enter at about index 35; looking at the images, one person already
  // walks in at the left edge from about index 19. So 0-18 is the truly empty room.
  const RangeStats empty_room = runRange(paths, 0, 18);
  const RangeStats first_30 = runRange(paths, 0, 29);
  const RangeStats people_a = runRange(paths, 60, 90);
  const RangeStats people_b = runRange(paths, 120, 150);
  print("bonn crowd, empty room (idx 0-18)", empty_room);
  print("bonn crowd, first 30 (person enters ~19)", first_30);
  print("bonn crowd, people (idx 60-90)", people_a);
  print("bonn crowd, people (idx 120-150)", people_b);
  // Coarse sanity: with people walking, far more of the image is masked than in the empty room,
  // in both stretches with people; and more once the first person has entered (from ~19).
  EXPECT_GT(people_a.mean_fraction, 3.0 * empty_room.mean_fraction);
  EXPECT_GT(people_b.mean_fraction, 3.0 * empty_room.mean_fraction);
  EXPECT_GT(first_30.mean_fraction, empty_room.mean_fraction);
  EXPECT_GT(first_30.max_fraction, empty_room.max_fraction);
  // In the empty room every masked pixel is a false positive; the camera moves slowly there, so
  // on average less than 5 % of the image may be masked.
  EXPECT_LT(empty_room.mean_fraction, 0.05);
}

TEST(FlowMaskRealData, TumRpyStaticSceneRotatingCamera) {
  const std::string folder = std::string(DYPHO_SHARED_DIR) + "/data/tum_fr1_rpy_first150";
  const auto paths = listImages(folder);
  if (paths.size() < 100) GTEST_SKIP() << "TUM fr1/rpy data not found in " << folder;
  // Static scene, mostly rotating hand-held camera: every masked pixel is a false positive.
  const RangeStats s = runRange(paths, 0, 149);
  print("tum fr1/rpy static scene (idx 0-149)", s);
  // fr1/rpy has fast rotations with strong motion blur, which break the flow in places. Without
  // the texture gate about 20 % of this static scene was masked on average; the bound of 10 %
  // guards that regression (not a target).
  EXPECT_LT(s.mean_fraction, 0.10);
}

}  // namespace
}  // namespace mask
}  // namespace dypho
