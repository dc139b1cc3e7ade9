// Unit tests of SyntheticScene: determinism, ground-truth consistency, depth noise, people
// coverage, trackable texture and render cost.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/tools/synthetic_scene.h"

using dypho::tools::SyntheticScene;
using dypho::tools::SynthFrame;
using dypho::tools::SynthMotion;
using dypho::tools::SynthOptions;

namespace DYPHO_UNITY_ID {

SynthOptions smallOptions(int people, std::uint32_t seed) {
  SynthOptions o;
  o.frames = 90;
  o.people = people;
  o.seed = seed;
  return o;
}

double fractionDifferent(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  if (diff.channels() > 1) diff = diff.reshape(1, static_cast<int>(diff.total()));
  return cv::countNonZero(diff) / static_cast<double>(diff.total());
}

TEST(SyntheticScene, SameSeedGivesIdenticalFramesInAnyOrder) {
  const SyntheticScene a(smallOptions(3, 7));
  const SyntheticScene b(smallOptions(3, 7));
  const SynthFrame later = b.render(40);  // b renders out of order
  const SynthFrame fa = a.render(20);
  const SynthFrame fb = b.render(20);
  EXPECT_EQ(fractionDifferent(fa.frame.bgr, fb.frame.bgr), 0.0);
  EXPECT_EQ(fractionDifferent(fa.frame.depth_m, fb.frame.depth_m), 0.0);  // noise included
  EXPECT_EQ(fractionDifferent(fa.mask_gt, fb.mask_gt), 0.0);
  EXPECT_EQ(fa.frame.stamp_ns, fb.frame.stamp_ns);
  EXPECT_TRUE(fa.T_world_camera.isApprox(fb.T_world_camera, 0.0));
  EXPECT_EQ(fractionDifferent(later.frame.bgr, a.render(40).frame.bgr), 0.0);
}

TEST(SyntheticScene, DifferentSeedGivesDifferentImages) {
  const SynthFrame fa = SyntheticScene(smallOptions(2, 1)).render(10);
  const SynthFrame fb = SyntheticScene(smallOptions(2, 2)).render(10);
  // Textures are drawn from the seed, so most pixels must change (same poses, same geometry).
  EXPECT_GT(fractionDifferent(fa.frame.bgr, fb.frame.bgr), 0.5);
  EXPECT_GT(fractionDifferent(fa.frame.depth_m, fb.frame.depth_m), 0.5);  // noise differs
}

TEST(SyntheticScene, MaskIsExactlyWherePeopleAreInFrontOfTheRoom) {
  SynthOptions o = smallOptions(3, 5);
  o.depth_noise = false;
  const SyntheticScene scene(o);
  int frames_with_people = 0;
  for (int i = 0; i < o.frames; i += 15) {
    const SynthFrame f = scene.render(i);
    ASSERT_EQ(f.mask_gt.type(), CV_8UC1);
    // People stand 2 cm above the floor and keep >= 0.2 m from walls and furniture, so a person
    // pixel is in front of the static surface by far more than 1 mm (float rounding ~1e-6 m).
    cv::Mat in_front = f.frame.depth_m < (f.static_depth_m - 1e-3);
    EXPECT_EQ(fractionDifferent(in_front, f.mask_gt), 0.0) << "frame " << i;
    cv::Mat behind = f.frame.depth_m > f.static_depth_m + 1e-6;
    EXPECT_EQ(cv::countNonZero(behind), 0) << "nothing can be behind the room, frame " << i;
    frames_with_people += cv::countNonZero(f.mask_gt) > 0;
  }
  EXPECT_GT(frames_with_people, 0) << "the check above is vacuous without people in view";
}

TEST(SyntheticScene, DepthNoiseMatchesKinectModel) {
  SynthOptions o;
  o.frames = 10;
  o.people = 0;
  o.motion = SynthMotion::kStatic;
  const SyntheticScene scene(o);
  // Residuals over 4 frames, normalised by the model sigma(z) combined with the uniform
  // quantisation error (step^2 / 12), binned by depth.
  const double q = 1.0 / 5000.0;
  struct Bin {
    double sum = 0, sum2 = 0;
    long n = 0;
  };
  std::vector<Bin> bins(10);  // 0.5 m bins from 0 to 5 m
  long zero = 0, total = 0, off_grid = 0;
  for (int i = 0; i < 4; ++i) {
    const SynthFrame f = scene.render(i);
    for (int v = 0; v < f.frame.depth_m.rows; ++v) {
      for (int u = 0; u < f.frame.depth_m.cols; ++u) {
        const double z = f.static_depth_m.at<float>(v, u);
        const double d = f.frame.depth_m.at<float>(v, u);
        ++total;
        if (d == 0.0) {
          ++zero;
          continue;
        }
        if (std::abs(d / q - std::round(d / q)) > 0.01) ++off_grid;
        const double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
        const double e = (d - z) / std::sqrt(sigma * sigma + q * q / 12.0);
        Bin& b = bins[std::min<std::size_t>(bins.size() - 1, static_cast<std::size_t>(z / 0.5))];
        b.sum += e;
        b.sum2 += e * e;
        ++b.n;
      }
    }
  }
  EXPECT_EQ(off_grid, 0) << "depth must be quantised to 1/5000 m";
  int checked = 0;
  for (std::size_t k = 0; k < bins.size(); ++k) {
    const Bin& b = bins[k];
    if (b.n < 5000) continue;  // too few pixels for a 7 % check
    const double mean = b.sum / b.n, sd = std::sqrt(b.sum2 / b.n - mean * mean);
    std::printf("depth %.1f-%.1f m: %ld px, normalised mean %.3f sd %.3f\n", 0.5 * k, 0.5 * k + 0.5, b.n, mean, sd);
    // Gaussian: the standard error of sd is 1/sqrt(2n) < 1 %; 7 % also absorbs the variation of
    // sigma(z) inside a 0.5 m bin (each pixel is normalised by its own sigma, so that is small).
    EXPECT_NEAR(sd, 1.0, 0.07) << "bin " << k;
    EXPECT_NEAR(mean, 0.0, 0.05) << "bin " << k;
    ++checked;
  }
  EXPECT_GE(checked, 3) << "the room should span at least three 0.5 m depth bins";
  // Holes: 1 % dropout plus thin bands at the few furniture edges -> between 1 % and 5 %.
  const double hole_fraction = static_cast<double>(zero) / total;
  EXPECT_GT(hole_fraction, 0.008);
  EXPECT_LT(hole_fraction, 0.05);
}

TEST(SyntheticScene, StaticSurfacesKeepTheirColourBetweenFrames) {
  SynthOptions o = smallOptions(0, 3);
  o.motion = SynthMotion::kStatic;  // sub-millimetre jitter
  const SyntheticScene scene(o);
  cv::Mat a, b;
  cv::cvtColor(scene.render(0).frame.bgr, a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(scene.render(30).frame.bgr, b, cv::COLOR_BGR2GRAY);
  // No specular term and no colour noise: only sub-pixel shifts of the texture remain, which
  // change a grey level by about one step on average.
  EXPECT_LT(cv::norm(a, b, cv::NORM_L1) / a.total(), 1.5);
}

TEST(SyntheticScene, PeopleCoverAGoodPartOfTheImage) {
  for (int people : {2, 3}) {
    SynthOptions o;  // default sequence: 300 frames, halfsphere
    o.people = people;
    o.depth_noise = false;
    const SyntheticScene scene(o);
    std::vector<double> coverage;
    for (int i = 0; i < o.frames; i += 6) {
      const SynthFrame f = scene.render(i);
      coverage.push_back(cv::countNonZero(f.mask_gt) / static_cast<double>(f.mask_gt.total()));
    }
    const double in_range =
        std::count_if(coverage.begin(), coverage.end(), [](double c) { return c >= 0.2 && c <= 0.5; }) /
        static_cast<double>(coverage.size());
    const double mean = std::accumulate(coverage.begin(), coverage.end(), 0.0) / coverage.size();
    const double max = *std::max_element(coverage.begin(), coverage.end());
    std::printf("%d people: mean coverage %.3f, max %.3f, frames in [0.2, 0.5]: %.0f %%\n", people, mean, max,
                100 * in_range);
    // Requirement: with 2-3 people, 20-50 % of the image for a good part of the sequence.
    EXPECT_GE(in_range, people == 3 ? 0.4 : 0.25);
    EXPECT_LE(max, 0.65) << "people must not fill the whole view";
  }
}

TEST(SyntheticScene, OrbFindsPlentyOfStaticFeatures) {
  for (SynthMotion m : {SynthMotion::kHalfsphere, SynthMotion::kLoop, SynthMotion::kRpy}) {
    SynthOptions o;
    o.motion = m;
    o.people = 3;
    const SyntheticScene scene(o);
    auto orb = cv::ORB::create(1000);
    for (int i = 0; i < o.frames; i += 75) {
      const SynthFrame f = scene.render(i);
      cv::Mat gray, static_px;
      cv::cvtColor(f.frame.bgr, gray, cv::COLOR_BGR2GRAY);
      cv::bitwise_not(f.mask_gt, static_px);
      std::vector<cv::KeyPoint> kps;
      orb->detect(gray, kps, static_px);
      EXPECT_GE(kps.size(), 500u) << dypho::tools::synthMotionName(m) << " frame " << i;
    }
  }
}

// render() is const and may be called in any order (the tests and benches jump around in a
// sequence): the same index gives the same images whatever was rendered before. (Its speed is
// measured by bench/, not asserted here.)
TEST(SyntheticScene, RenderIsRepeatableInAnyOrder) {
  const SyntheticScene scene(SynthOptions{});
  const SynthFrame first = scene.render(14);
  scene.render(3);
  scene.render(200);
  const SynthFrame again = scene.render(14);
  EXPECT_EQ(cv::norm(first.frame.bgr, again.frame.bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(first.frame.depth_m, again.frame.depth_m, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(first.mask_gt, again.mask_gt, cv::NORM_INF), 0.0);
  EXPECT_TRUE(first.T_world_camera.isApprox(again.T_world_camera, 0.0));
  EXPECT_EQ(first.frame.stamp_ns, again.frame.stamp_ns);
}

TEST(SyntheticScene, RejectsBadOptionsWithClearErrors) {
  SynthOptions o;
  o.people = 9;
  EXPECT_THROW(SyntheticScene{o}, std::runtime_error);
  o = SynthOptions{};
  o.frames = 0;
  EXPECT_THROW(o.validate(), std::runtime_error);
  o = SynthOptions{};
  o.camera.distortion[0] = 0.1;
  EXPECT_THROW(o.validate(), std::runtime_error);
  o = SynthOptions{};
  o.motion = SynthMotion::kLoop;
  o.frames = 100;  // 360 deg in 3.3 s is far above 40 deg/s
  try {
    o.validate();
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("use at least"), std::string::npos) << e.what();
  }
  try {
    dypho::tools::parseSynthMotion("circle");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("halfsphere"), std::string::npos) << e.what();
  }
  EXPECT_EQ(dypho::tools::parseSynthMotion("rpy"), SynthMotion::kRpy);
  const SyntheticScene scene(smallOptions(1, 1));
  EXPECT_THROW(scene.render(90), std::out_of_range);
  EXPECT_THROW(scene.render(-1), std::out_of_range);
}

// catkin_add_gtest links gtest without gtest_main; defining main here also works with
// GTest::gtest_main (a static library whose main is then not pulled in).
}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
