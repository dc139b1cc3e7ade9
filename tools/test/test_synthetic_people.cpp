// Unit tests of the synthetic people: the default layout is unchanged, the walk styles do what they
// promise (standing still, walking towards the camera, walking as a group), people can start in
// view and fill the view, and nobody walks into anybody else or into the camera.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "dypho/tools/synthetic_scene.h"
#include "synthetic_internal.h"  // paths and states of the people (tools/src)

using dypho::tools::SyntheticScene;
using dypho::tools::SynthFrame;
using dypho::tools::SynthMotion;
using dypho::tools::SynthOptions;
using dypho::tools::SynthWalk;
namespace sd = dypho::tools::synth_detail;

namespace DYPHO_UNITY_ID {

constexpr double kPi = 3.14159265358979323846;

/// The default camera scaled to 160 x 120 (same field of view, 16x fewer rays).
dypho::CameraIntrinsics smallCamera() {
  dypho::CameraIntrinsics c = dypho::tools::defaultSynthCamera();
  c.width = 160;
  c.height = 120;
  c.fx = c.fy = 525.0 / 4;
  c.cx = 79.5;
  c.cy = 59.5;
  return c;
}

SynthOptions options(SynthMotion motion, int people, SynthWalk walk = SynthWalk::kCross, bool in_view = false,
                     double distance_m = 0.0) {
  SynthOptions o;
  o.motion = motion;
  o.people = people;
  o.walk = walk;
  o.people_in_view_at_start = in_view;
  o.people_distance_m = distance_m;
  o.camera = smallCamera();
  o.depth_noise = false;
  return o;
}

/// The people's paths exactly as SyntheticScene builds them (same seeding of the RNG).
std::vector<sd::PersonPath> pathsOf(const SynthOptions& o) {
  cv::RNG people_rng(0x77E1ULL ^ (static_cast<std::uint64_t>(o.seed) * 40503ULL + 1));
  return sd::makePeoplePaths(o, people_rng);
}

/// States of every person at `fps` over `duration_s` ([sample][person]).
std::vector<std::vector<sd::PersonState>> trackStates(const std::vector<sd::PersonPath>& paths, double duration_s,
                                                      double fps = 30.0) {
  std::vector<std::vector<sd::PersonState>> out;
  for (int i = 0; i <= static_cast<int>(duration_s * fps); ++i) {
    out.emplace_back();
    for (const auto& p : paths) out.back().push_back(sd::personStateAt(p, i / fps));
  }
  return out;
}

/// Positions of every person at `fps` over `duration_s` ([sample][person]).
std::vector<std::vector<Eigen::Vector2d>> track(const std::vector<sd::PersonPath>& paths, double duration_s,
                                                double fps = 30.0) {
  std::vector<std::vector<Eigen::Vector2d>> out;
  for (const auto& states : trackStates(paths, duration_s, fps)) {
    out.emplace_back();
    for (const auto& s : states) out.back().push_back(s.position);
  }
  return out;
}

/// Runs [first, last] of >= 1 s of samples at which person `k` stands: same position and same
/// heading (turning round on the spot is not standing).
std::vector<std::pair<int, int>> stands(const std::vector<std::vector<sd::PersonState>>& states, std::size_t k,
                                        double fps) {
  std::vector<std::pair<int, int>> out;
  int first = 0;
  const int n = static_cast<int>(states.size());
  for (int i = 1; i <= n; ++i) {
    if (i == n || states[i][k].position != states[first][k].position ||
        states[i][k].heading != states[first][k].heading) {
      if ((i - 1 - first) / fps >= 1.0) out.emplace_back(first, i - 1);
      first = i;
    }
  }
  return out;
}

std::uint64_t fnv1a(const cv::Mat& m, std::uint64_t h = 1469598103934665603ULL) {
  for (int r = 0; r < m.rows; ++r) {
    const auto* p = m.ptr<std::uint8_t>(r);
    for (std::size_t i = 0; i < m.cols * m.elemSize(); ++i) {
      h ^= p[i];
      h *= 1099511628211ULL;
    }
  }
  return h;
}

double coverage(const SynthFrame& f) { return cv::countNonZero(f.mask_gt) / static_cast<double>(f.mask_gt.total()); }

std::string describe(const SynthOptions& o) { return o.toString(); }

// The people layout before the walk styles (commit d83779e, makePeoplePaths), copied here: the
// default options must keep drawing the same numbers in the same order.
std::vector<sd::PersonPath> layoutBeforeWalkStyles(const SynthOptions& o, cv::RNG& rng) {
  std::vector<sd::PersonPath> paths;
  for (int k = 0; k < o.people; ++k) {
    sd::PersonPath p;
    const double speed_ms = rng.uniform(0.7, 1.1);
    if (o.motion == SynthMotion::kLoop) {
      const double r = sd::loopRadiusM(o);
      const double duration_s = std::max(o.frames - 1, 1) / o.fps;
      p.centre = Eigen::Vector2d(0.0, 0.0);
      p.ax = std::min(2.55, r + 1.1 + 0.15 * k);
      p.ay = std::min(2.2, r + 0.8 + 0.15 * k);
      p.omega = 2.0 * kPi / duration_s;
      p.phase = 0.5 * kPi + 0.45 * (k - 1) + rng.uniform(-0.15, 0.15);
      p.wobble_phase = rng.uniform(0.0, 2.0 * kPi);
      p.wobble_omega = 2.0 * kPi / rng.uniform(4.0, 7.0);
      p.wobble_amp = std::min(rng.uniform(0.15, 0.3), 0.8 * p.omega / p.wobble_omega);
    } else {
      p.centre = Eigen::Vector2d(rng.uniform(-0.2, 0.2), 0.8 + 0.45 * k + rng.uniform(-0.05, 0.05));
      p.ax = rng.uniform(0.9, 1.5);
      p.ay = 0.15;
      const double mean_radius = std::sqrt(0.5 * (p.ax * p.ax + p.ay * p.ay));
      p.omega = (rng.uniform(0, 2) == 0 ? -1.0 : 1.0) * speed_ms / mean_radius;
      p.phase = rng.uniform(0.0, 2.0 * kPi);
    }
    paths.push_back(p);
  }
  return paths;
}

// ---------------------------------------------------------------------------------------------
// Defaults

TEST(SynthPeople, DefaultPathsAreDrawnAsBefore) {
  for (SynthMotion m :
       {SynthMotion::kXyz, SynthMotion::kHalfsphere, SynthMotion::kStatic, SynthMotion::kRpy, SynthMotion::kLoop}) {
    for (int people = 0; people <= 3; ++people) {
      for (std::uint32_t seed : {1u, 2u, 77u}) {
        SynthOptions o = options(m, people);
        o.seed = seed;
        ASSERT_TRUE(sd::usesLegacyPeopleLayout(o));
        cv::RNG rng(0x77E1ULL ^ (static_cast<std::uint64_t>(seed) * 40503ULL + 1));
        const auto expected = layoutBeforeWalkStyles(o, rng);
        const auto got = pathsOf(o);
        ASSERT_EQ(got.size(), expected.size());
        for (std::size_t k = 0; k < got.size(); ++k) {
          const auto &g = got[k], &e = expected[k];
          EXPECT_TRUE(g.legs.empty());
          EXPECT_EQ(g.centre, e.centre);
          EXPECT_EQ(g.ax, e.ax);
          EXPECT_EQ(g.ay, e.ay);
          EXPECT_EQ(g.omega, e.omega);
          EXPECT_EQ(g.phase, e.phase);
          EXPECT_EQ(g.wobble_amp, e.wobble_amp);
          EXPECT_EQ(g.wobble_omega, e.wobble_omega);
          EXPECT_EQ(g.wobble_phase, e.wobble_phase);
        }
      }
    }
  }
}

// FNV-1a 64 checksums of the raw bytes (BGR, float depth with noise, mask) of three frames at
// 160 x 120, printed by this test's code linked against the renderer BEFORE the walk styles
// (commit d83779e, Release build, GCC 12 on x86-64). Textures, shading and noise are computed in
// double/float, so another compiler or CPU could change a few bits without any real change: if
// this fails there while DefaultPathsAreDrawnAsBefore passes, compare the images of the old and
// the new dypho_synth with cmp instead.
TEST(SynthPeople, DefaultFramesAreBitIdenticalToBefore) {
  struct Golden {
    SynthMotion motion;
    int people;
    std::uint32_t seed;
    int frames, index;
    std::uint64_t bgr, depth, mask;
  };
  const Golden goldens[] = {
      {SynthMotion::kStatic, 3, 4, 40, 25, 0x3e3b56e79b07bef3ULL, 0x12e7d9e9d611e736ULL, 0xd1a2c2e19736da54ULL},
      {SynthMotion::kHalfsphere, 2, 1, 40, 12, 0x6eabfba7dc324398ULL, 0x36509cab344e2c45ULL, 0xb7589472e57c86e5ULL},
      {SynthMotion::kLoop, 3, 5, 300, 100, 0x8f644bbf53a0a0dbULL, 0xbcd90e373914170aULL, 0xf3bce62e29f3e79fULL},
  };
  for (const Golden& g : goldens) {
    SynthOptions o;  // defaults, noise on
    o.motion = g.motion;
    o.people = g.people;
    o.seed = g.seed;
    o.frames = g.frames;
    o.camera = smallCamera();
    const SynthFrame f = SyntheticScene(o).render(g.index);
    EXPECT_GT(cv::countNonZero(f.mask_gt), 1000) << "the frame must show people";
    EXPECT_EQ(fnv1a(f.frame.bgr), g.bgr) << describe(o);
    EXPECT_EQ(fnv1a(f.frame.depth_m), g.depth) << describe(o);
    EXPECT_EQ(fnv1a(f.mask_gt), g.mask) << describe(o);
  }
}

// ---------------------------------------------------------------------------------------------
// Ground truth per person

TEST(SynthPeople, PersonIdsMatchTheMask) {
  const SyntheticScene scene(options(SynthMotion::kStatic, 8, SynthWalk::kCross, true, 0.9));
  const SynthFrame f = scene.render(0);
  ASSERT_EQ(f.person_id_gt.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero((f.person_id_gt > 0) != (f.mask_gt == 255)), 0);
  double lo = 0, hi = 0;
  cv::minMaxLoc(f.person_id_gt, &lo, &hi);
  EXPECT_EQ(hi, 8.0);
}

// ---------------------------------------------------------------------------------------------
// People in view at frame 0

TEST(SynthPeople, EveryPersonIsInsideTheFirstImage) {
  struct Case {
    SynthMotion motion;
    int people;
    SynthWalk walk;
    double distance_m;
    bool each_visible;  ///< also check that nobody is completely hidden behind others
  };
  const Case cases[] = {
      {SynthMotion::kStatic, 6, SynthWalk::kCross, 1.0, true},
      {SynthMotion::kStatic, 1, SynthWalk::kCross, 0.0, true},
      {SynthMotion::kStatic, 5, SynthWalk::kStopAndGo, 0.0, true},
      {SynthMotion::kStatic, 5, SynthWalk::kTowards, 0.0, true},
      {SynthMotion::kStatic, 8, SynthWalk::kGroup, 0.0, false},  // two ranks: members may hide each other
      {SynthMotion::kStatic, 8, SynthWalk::kCross, 0.7, false},
      {SynthMotion::kHalfsphere, 8, SynthWalk::kStopAndGo, 0.0, false},
      {SynthMotion::kXyz, 3, SynthWalk::kTowards, 1.2, true},
      {SynthMotion::kRpy, 4, SynthWalk::kGroup, 0.0, true},
      {SynthMotion::kLoop, 5, SynthWalk::kCross, 0.0, true},
  };
  for (const Case& c : cases) {
    for (std::uint32_t seed : {1u, 2u}) {
      SynthOptions o = options(c.motion, c.people, c.walk, true, c.distance_m);
      o.seed = seed;
      const SyntheticScene scene(o);
      const SynthFrame f = scene.render(0);
      const auto paths = pathsOf(o);
      ASSERT_EQ(static_cast<int>(paths.size()), c.people);
      for (int k = 0; k < c.people; ++k) {
        const sd::BodySpan span = sd::bodySpan(sd::personStateAt(paths[k], 0.0).position, f.T_world_camera, o.camera);
        EXPECT_TRUE(span.inside) << "person " << k << " columns " << span.u_lo << ".." << span.u_hi << ", "
                                 << describe(o);
        const int pixels = cv::countNonZero(f.person_id_gt == k + 1);
        EXPECT_GT(pixels, 0) << "person " << k << " is not in the image, " << describe(o);
        // 0.5 % of the image: more than a head peeking out behind someone.
        if (c.each_visible) {
          EXPECT_GT(pixels, 0.005 * f.mask_gt.total()) << "person " << k << ", " << describe(o);
        }
      }
      // Each body is at least 0.5 m wide at <= 3.3 m: with this many people the first image is
      // well covered.
      EXPECT_GT(coverage(f), 0.02 * c.people) << describe(o);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Density: the commands documented in `dypho_synth --help` and the README

TEST(SynthPeople, DensityOptionFillsAStaticView) {
  struct Case {
    int people;
    bool in_view;
    double distance_m;
    double min_mean, min_max;
  };
  // (a) dypho_synth --motion static --people 6 --people-in-view --people-distance 0.9
  // (b) dypho_synth --motion static --people 8 --people-distance 0.8
  const Case cases[] = {{6, true, 0.9, 0.30, 0.45}, {8, false, 0.8, 0.42, 0.55}};
  for (const Case& c : cases) {
    const SynthOptions o = options(SynthMotion::kStatic, c.people, SynthWalk::kCross, c.in_view, c.distance_m);
    const SyntheticScene scene(o);
    double sum = 0.0, max = 0.0;
    const int frames = 60;
    for (int i = 0; i < frames; ++i) {
      const double cov = coverage(scene.render(i));
      sum += cov;
      max = std::max(max, cov);
    }
    std::printf("%d people at %.1f m: mean coverage %.3f, max %.3f over %d frames\n", c.people, c.distance_m,
                sum / frames, max, frames);
    EXPECT_GE(sum / frames, c.min_mean) << describe(o);
    EXPECT_GE(max, c.min_max) << describe(o);
    EXPECT_LE(max, 0.8) << "the room must stay visible, " << describe(o);
  }
}

// ---------------------------------------------------------------------------------------------
// Walk styles

TEST(SynthPeople, StopAndGoStandsStillWhileOthersWalk) {
  const double fps = 30.0;
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    SynthOptions o = options(SynthMotion::kStatic, 4, SynthWalk::kStopAndGo);
    o.seed = seed;
    const auto paths = pathsOf(o);
    const auto states = trackStates(paths, 60.0, fps);
    for (std::size_t k = 0; k < paths.size(); ++k) {
      const auto runs = stands(states, k, fps);
      ASSERT_GE(runs.size(), 3u) << "person " << k << " stands still for >= 1 s only " << runs.size()
                                 << " times in 60 s, seed " << seed;
      // While person k stands, somebody else walks (the sequence is not frozen).
      const auto [a, b] = runs.front();
      double others_moved = 0.0;
      for (std::size_t j = 0; j < paths.size(); ++j) {
        if (j != k) others_moved = std::max(others_moved, (states[b][j].position - states[a][j].position).norm());
      }
      EXPECT_GT(others_moved, 0.1) << "person " << k << ", seed " << seed;
      // Irregular: the times between stands differ by more than half a second.
      double shortest = std::numeric_limits<double>::infinity(), longest = 0.0;
      for (std::size_t s = 1; s < runs.size(); ++s) {
        const double between_s = (runs[s].first - runs[s - 1].second) / fps;
        shortest = std::min(shortest, between_s);
        longest = std::max(longest, between_s);
      }
      EXPECT_GT(longest - shortest, 0.5) << "person " << k << ", seed " << seed;
      // Smooth: no jumps between frames (1.5 m/s is 5 cm per frame).
      for (std::size_t i = 1; i < states.size(); ++i) {
        ASSERT_LE((states[i][k].position - states[i - 1][k].position).norm(), 1.5 / fps) << "sample " << i;
        ASSERT_TRUE(std::isfinite(states[i][k].heading));
      }
    }
  }
  // People crossing the view only stop to turn round.
  const auto paths = pathsOf(options(SynthMotion::kStatic, 4, SynthWalk::kCross, false, 1.0));
  const auto states = trackStates(paths, 60.0, fps);
  for (std::size_t k = 0; k < paths.size(); ++k) EXPECT_TRUE(stands(states, k, fps).empty()) << "person " << k;
}

TEST(SynthPeople, TowardsWalksAlongTheViewFromFarToNear) {
  for (SynthMotion m : {SynthMotion::kStatic, SynthMotion::kHalfsphere}) {
    const SynthOptions o = options(m, 3, SynthWalk::kTowards);
    const auto paths = pathsOf(o);
    const auto pos = track(paths, 20.0);
    for (std::size_t k = 0; k < paths.size(); ++k) {
      double nearest = std::numeric_limits<double>::infinity(), farthest = 0.0;
      double along_view = 0.0, walked = 0.0;  // |dy| against |d(x, y)| summed over the walk
      for (std::size_t i = 0; i < pos.size(); ++i) {
        const Eigen::Vector2d camera = sd::cameraPoseAt(o, i / 30.0).translation().head<2>();
        const double d = (pos[i][k] - camera).norm();
        nearest = std::min(nearest, d);
        farthest = std::max(farthest, d);
        if (i > 0) {
          along_view += std::abs(pos[i][k].y() - pos[i - 1][k].y());
          walked += (pos[i][k] - pos[i - 1][k]).norm();
        }
      }
      EXPECT_GE(farthest - nearest, 1.5) << "person " << k << ", " << describe(o);
      EXPECT_GT(farthest, 2.5) << "person " << k;
      EXPECT_LT(nearest, 1.5) << "person " << k;
      EXPECT_GT(along_view, 0.9 * walked) << "person " << k << " walks across, not towards";
    }
  }
}

TEST(SynthPeople, GroupWalksWithOneVelocity) {
  for (int people : {2, 5, 8}) {
    const SynthOptions o = options(SynthMotion::kStatic, people, SynthWalk::kGroup);
    const auto paths = pathsOf(o);
    const auto pos = track(paths, 20.0);
    double fastest = 0.0;
    for (std::size_t i = 1; i < pos.size(); ++i) {
      const Eigen::Vector2d v0 = (pos[i][0] - pos[i - 1][0]) * 30.0;
      fastest = std::max(fastest, v0.norm());
      for (std::size_t k = 1; k < paths.size(); ++k) {
        const Eigen::Vector2d vk = (pos[i][k] - pos[i - 1][k]) * 30.0;
        ASSERT_LT((vk - v0).norm(), 1e-9) << "person " << k << " at sample " << i;
      }
    }
    EXPECT_GT(fastest, 0.5) << "the group must walk";
    // Side by side: close together (within 2.5 m of the first member) but apart.
    for (std::size_t k = 1; k < paths.size(); ++k) EXPECT_LT((pos[0][k] - pos[0][0]).norm(), 2.5);
  }
}

// ---------------------------------------------------------------------------------------------
// Safety: speeds, distances to each other, to the camera and to the furniture

TEST(SynthPeople, NobodyRunsOrWalksIntoAnybodyOrTheCamera) {
  // Furniture boxes of the scene (synthetic_scene.cpp) on the floor plan, and the room.
  const Eigen::Vector4d boxes[] = {{-3.0, 2.45, -1.6, 3.0},
                                   {1.7, 2.55, 2.6, 3.0},
                                   {3.0, -1.2, 3.5, 0.4},
                                   {-3.5, -0.5, -2.9, 0.6},
                                   {-0.8, -3.0, 0.6, -2.5}};
  struct Worst {
    double separation = 1e9, camera = 1e9, furniture = 1e9, speed = 0, acceleration = 0;
  };
  auto check = [&](const SynthOptions& o) {
    const auto paths = pathsOf(o);
    const double fps = 30.0;
    const double duration_s = o.motion == SynthMotion::kLoop ? (o.frames - 1) / o.fps : 60.0;
    const auto pos = track(paths, duration_s, fps);
    Worst w;
    for (std::size_t i = 0; i < pos.size(); ++i) {
      const Eigen::Vector2d camera = sd::cameraPoseAt(o, i / fps).translation().head<2>();
      for (std::size_t k = 0; k < pos[i].size(); ++k) {
        const Eigen::Vector2d& p = pos[i][k];
        w.camera = std::min(w.camera, (p - camera).norm());
        for (std::size_t j = k + 1; j < pos[i].size(); ++j)
          w.separation = std::min(w.separation, (p - pos[i][j]).norm());
        for (const auto& b : boxes) {
          const Eigen::Vector2d q(std::clamp(p.x(), b[0], b[2]), std::clamp(p.y(), b[1], b[3]));
          w.furniture = std::min(w.furniture, (p - q).norm());
        }
        w.furniture = std::min({w.furniture, 3.5 - std::abs(p.x()), 3.0 - std::abs(p.y())});
        if (i >= 1) w.speed = std::max(w.speed, (p - pos[i - 1][k]).norm() * fps);
        if (i >= 2)
          w.acceleration = std::max(w.acceleration, (p - 2 * pos[i - 1][k] + pos[i - 2][k]).norm() * fps * fps);
      }
    }
    return w;
  };
  int checked = 0;
  for (SynthMotion m : {SynthMotion::kStatic, SynthMotion::kXyz, SynthMotion::kHalfsphere, SynthMotion::kRpy}) {
    for (SynthWalk walk : {SynthWalk::kCross, SynthWalk::kStopAndGo, SynthWalk::kTowards, SynthWalk::kGroup}) {
      for (int people : {3, 8}) {
        for (double distance_m : {0.0, sd::minPeopleDistanceM(options(m, people, walk))}) {
          SynthOptions o = options(m, people, walk, people == 3, distance_m);
          o.seed = static_cast<std::uint32_t>(checked % 5 + 1);
          const Worst w = check(o);
          EXPECT_GE(w.separation, 0.5) << describe(o);
          EXPECT_GE(w.camera, 0.599) << describe(o);    // 0.6 m, less the static camera's jitter
          EXPECT_GE(w.furniture, 0.27) << describe(o);  // body half width 0.25
          EXPECT_LE(w.speed, 1.5) << describe(o);
          EXPECT_LE(w.acceleration, 3.0) << describe(o);
          ++checked;
        }
      }
    }
  }
  for (int frames : {271, 600}) {
    for (int people : {4, 8}) {
      SynthOptions o = options(SynthMotion::kLoop, people);
      o.frames = frames;
      const Worst w = check(o);
      EXPECT_GE(w.separation, 0.5) << describe(o);
      EXPECT_GE(w.camera, 0.6) << describe(o);
      EXPECT_GE(w.furniture, 0.27) << describe(o);
      EXPECT_LE(w.speed, 1.5) << describe(o);
      ++checked;
    }
  }
  // The layout of earlier versions keeps people away from the camera too (their speeds and
  // spacing are as they were: up to about 2 m/s on short loops, and lanes can touch).
  for (SynthMotion m : {SynthMotion::kStatic, SynthMotion::kXyz, SynthMotion::kHalfsphere, SynthMotion::kLoop}) {
    const SynthOptions o = options(m, 3);
    EXPECT_GE(check(o).camera, 0.6) << describe(o);
  }
  std::printf("checked %d layouts\n", checked);
}

TEST(SynthPeople, NewLayoutsAreDeterministicAndSeeded) {
  SynthOptions o = options(SynthMotion::kStatic, 5, SynthWalk::kStopAndGo, true, 0.9);
  const SynthFrame a = SyntheticScene(o).render(17), b = SyntheticScene(o).render(17);
  EXPECT_EQ(cv::norm(a.frame.bgr, b.frame.bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.person_id_gt, b.person_id_gt, cv::NORM_INF), 0.0);
  const auto first = pathsOf(o);
  o.seed = 2;
  const auto second = pathsOf(o);
  ASSERT_EQ(first.size(), second.size());
  int differ = 0;
  for (std::size_t k = 0; k < first.size(); ++k) {
    differ += (sd::personStateAt(first[k], 3.0).position - sd::personStateAt(second[k], 3.0).position).norm() > 1e-6;
  }
  EXPECT_GT(differ, 0);
  // The lane layout does not depend on the sequence length.
  o.frames = 40;
  const auto shorter = pathsOf(o);
  for (std::size_t k = 0; k < second.size(); ++k) {
    EXPECT_EQ(sd::personStateAt(second[k], 1.0).position, sd::personStateAt(shorter[k], 1.0).position);
  }
}

// ---------------------------------------------------------------------------------------------
// Options

TEST(SynthPeople, RejectsImpossibleRequestsWithClearErrors) {
  auto error = [](const SynthOptions& o) -> std::string {
    try {
      o.validate();
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  };
  auto expectError = [&](const SynthOptions& o, const std::string& part) {
    const std::string e = error(o);
    EXPECT_NE(e.find(part), std::string::npos) << "expected '" << part << "' in '" << e << "' for " << describe(o);
  };
  expectError(options(SynthMotion::kStatic, 9), "people = 9 must be in 0..8");
  expectError(options(SynthMotion::kLoop, 3, SynthWalk::kTowards), "walk = towards");
  expectError(options(SynthMotion::kLoop, 3, SynthWalk::kCross, false, 1.0), "must be 0 (auto) for the loop");
  expectError(options(SynthMotion::kLoop, 6, SynthWalk::kCross, true), "at most 5 people");
  expectError(options(SynthMotion::kStatic, 2, SynthWalk::kCross, false, 0.5), "in [0.6, ");
  expectError(options(SynthMotion::kXyz, 2, SynthWalk::kCross, false, 0.7), "in [0.8, ");
  expectError(options(SynthMotion::kStatic, 2, SynthWalk::kCross, false, 3.0), "furniture");
  expectError(options(SynthMotion::kStatic, 2, SynthWalk::kTowards, false, 2.5), "people_distance_m = 2.5");
  expectError(options(SynthMotion::kStatic, 6, SynthWalk::kTowards, true), "at most 5 lanes");
  expectError(options(SynthMotion::kStatic, 8, SynthWalk::kGroup, true, 0.9), "two ranks");
  expectError(options(SynthMotion::kStatic, 2, SynthWalk::kCross, false, -1.0), "people_distance_m = -1");
  expectError(options(SynthMotion::kStatic, 2, SynthWalk::kCross, false, std::nan("")), "people_distance_m = nan");
  // What the documentation promises is accepted.
  for (SynthMotion m : {SynthMotion::kStatic, SynthMotion::kXyz, SynthMotion::kHalfsphere, SynthMotion::kRpy}) {
    for (SynthWalk walk : {SynthWalk::kCross, SynthWalk::kStopAndGo, SynthWalk::kTowards, SynthWalk::kGroup}) {
      for (int people = 0; people <= 8; ++people) {
        const SynthOptions o = options(m, people, walk, walk != SynthWalk::kTowards || people <= 5);
        EXPECT_EQ(error(o), "") << describe(o);
      }
    }
  }
  EXPECT_EQ(error(options(SynthMotion::kStatic, 6, SynthWalk::kCross, true, 1.0)), "");
  EXPECT_EQ(error(options(SynthMotion::kStatic, 8, SynthWalk::kCross, false, 0.8)), "");
  EXPECT_EQ(error(options(SynthMotion::kLoop, 5, SynthWalk::kCross, true)), "");
  try {
    dypho::tools::parseSynthWalk("zigzag");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("stop-and-go"), std::string::npos) << e.what();
  }
  for (SynthWalk w : {SynthWalk::kCross, SynthWalk::kStopAndGo, SynthWalk::kTowards, SynthWalk::kGroup}) {
    EXPECT_EQ(dypho::tools::parseSynthWalk(dypho::tools::synthWalkName(w)), w);
  }
  const std::string text = options(SynthMotion::kStatic, 5, SynthWalk::kStopAndGo, true, 0.9).toString();
  EXPECT_NE(text.find("people=5 walk=stop-and-go people_in_view_at_start=true people_distance_m=0.9"),
            std::string::npos)
      << text;
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
