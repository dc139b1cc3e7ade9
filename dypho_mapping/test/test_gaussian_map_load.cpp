/// Loading a saved Gaussian map back into a mapper (GaussianMapper::loadPly, the core of the
/// mapping nodelet's ~load_map service and ~map_load_path): the loaded map renders like the saved
/// one, also with the worker thread running; a corrupt or truncated file is rejected with an error
/// naming the file and the problem, and the current map is left untouched.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "dypho/mapping/gaussian_mapper.h"
#include "plane_keyframe.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

std::string tempPath(const std::string& name) {
  return "/tmp/dypho_test_map_load_" + std::to_string(::getpid()) + "_" + name;
}

/// A textured fronto-parallel plane at 2 m seen from `T_world_camera`.
Keyframe planeKeyframe(std::int64_t id, const Eigen::Isometry3d& T_world_camera) {
  return test::texturedPlaneKeyframe(id, T_world_camera, 96, 72, 80.0, 8);
}

GaussianMapperOptions smallOptions() {
  GaussianMapperOptions o;
  o.train_downsample = 1;
  o.coverage_stride_px = 4;
  o.feature_samples = 0;
  o.sh_degree = 2;  // view-dependent coefficients go through the file too
  return o;
}

Eigen::Isometry3d sidePose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.15, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(-0.2, 0.05, 0.1);
  return T;
}

/// Largest difference of two renders (colour in 8-bit steps, depth in m, alpha).
struct RenderDiff {
  double bgr = 0, depth_m = 0, alpha = 0;
};
RenderDiff diff(const RenderedView& a, const RenderedView& b) {
  return {cv::norm(a.bgr, b.bgr, cv::NORM_INF), cv::norm(a.depth_m, b.depth_m, cv::NORM_INF),
          cv::norm(a.alpha, b.alpha, cv::NORM_INF)};
}

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// A mapper with a trained (non-trivial) map, saved to `ply`.
void trainedMapper(GaussianMapper& mapper, const std::string& ply) {
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(1, Eigen::Isometry3d::Identity())).added);
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(2, sidePose())).added);
  mapper.optimize(5);
  mapper.savePly(ply);
}

TEST(GaussianMapLoad, LoadedMapRendersLikeTheSavedOneWithTheWorkerRunning) {
  const std::string ply = tempPath("map.ply");
  GaussianMapper saved(smallOptions());
  trainedMapper(saved, ply);
  GaussianMapper loaded(smallOptions());
  loaded.start(4);  // the worker runs (idle) while the map is replaced
  std::string note = "stale";
  EXPECT_EQ(loaded.loadPly(ply, &note), saved.stats().num_gaussians);
  EXPECT_EQ(note, "");  // same degree, within capacity: nothing adapted
  EXPECT_EQ(loaded.stats().num_gaussians, saved.stats().num_gaussians);
  // Views and clouds read the snapshot: it holds the loaded map at once, before any keyframe (a
  // localisation-only run never sends one).
  const MapSnapshot snapshot = loaded.latestSnapshot();
  ASSERT_TRUE(snapshot.map);
  EXPECT_EQ(snapshot.map->size(), saved.stats().num_gaussians);
  const Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
  for (const Eigen::Isometry3d& T : {Eigen::Isometry3d::Identity(), sidePose()}) {
    const RenderedView a = saved.render(T, kf.frame.camera), b = loaded.render(T, kf.frame.camera);
    const RenderDiff d = diff(a, b);
    // The PLY stores the float parameters bit for bit and the renderer is deterministic, so the
    // bound is float rounding only: 1e-5 m / 1e-5 alpha, at most one 8-bit step of colour.
    EXPECT_LE(d.bgr, 1.0);
    EXPECT_LE(d.depth_m, 1e-5);
    EXPECT_LE(d.alpha, 1e-5);
    EXPECT_GT(cv::mean(a.alpha)[0], 0.5);  // the map really covers the view
  }
  // The worker keeps training on the loaded map.
  Keyframe next = planeKeyframe(3, Eigen::Isometry3d::Identity());
  EXPECT_TRUE(loaded.enqueueKeyframe(std::make_shared<Keyframe>(next), /*block_when_full=*/true));
  loaded.waitUntilIdle();
  EXPECT_GE(loaded.stats().num_gaussians, saved.stats().num_gaussians);
  loaded.stop();
  std::remove(ply.c_str());
}

TEST(GaussianMapLoad, CorruptOrTruncatedFileLeavesTheMapUntouched) {
  const std::string ply = tempPath("good.ply"), bad = tempPath("bad.ply");
  GaussianMapper mapper(smallOptions());
  trainedMapper(mapper, ply);
  const Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
  const RenderedView before = mapper.render(sidePose(), kf.frame.camera);
  const std::size_t count = mapper.stats().num_gaussians;
  ASSERT_GT(count, 100u);
  const std::string bytes = fileBytes(ply);
  const std::size_t header_end = bytes.find("end_header\n") + 11;
  struct Case {
    std::string name, content, expect;  ///< expect: a word the error message must contain
  };
  const Case cases[] = {
      {"truncated payload", bytes.substr(0, bytes.size() - 7), "truncated"},
      {"header only", bytes.substr(0, header_end), "truncated"},
      {"cut inside the header", bytes.substr(0, header_end / 2), "end_header"},
      {"not a PLY", "solid cube\nfacet normal 0 0 1\n", "not a PLY"},
      {"empty file", "", "not a PLY"},
      {"ASCII PLY", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
       "binary_little_endian"},
      {"missing property",
       "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\nend_header\n",
       "missing property"},
  };
  for (const Case& c : cases) {
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << c.content;
    try {
      mapper.loadPly(bad);
      ADD_FAILURE() << c.name << ": accepted";
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(bad), std::string::npos) << c.name << ": " << msg;       // names the file
      EXPECT_NE(msg.find(c.expect), std::string::npos) << c.name << ": " << msg;  // and the problem
    }
    EXPECT_EQ(mapper.stats().num_gaussians, count) << c.name;
  }
  EXPECT_THROW(mapper.loadPly(tempPath("does_not_exist.ply")), std::runtime_error);
  // Untouched: renders exactly as before (same parameters, same deterministic renderer).
  const RenderDiff d = diff(before, mapper.render(sidePose(), kf.frame.camera));
  EXPECT_EQ(d.bgr, 0.0);
  EXPECT_EQ(d.depth_m, 0.0);
  EXPECT_EQ(d.alpha, 0.0);
  std::remove(ply.c_str());
  std::remove(bad.c_str());
}

TEST(GaussianMapLoad, LoadWhileTheWorkerTrainsAndRendersRun) {
  // Loads race with the worker's iterations and with renders; every load either fully replaces
  // the map or (bad file) changes nothing, and nothing crashes or deadlocks.
  const std::string ply = tempPath("race.ply"), bad = tempPath("race_bad.ply");
  std::size_t saved_count = 0;
  {
    GaussianMapper source(smallOptions());
    trainedMapper(source, ply);
    saved_count = source.stats().num_gaussians;
  }
  std::ofstream(bad, std::ios::binary) << fileBytes(ply).substr(0, 300);
  GaussianMapperOptions o = smallOptions();
  o.iterations_per_keyframe = 5;
  GaussianMapper mapper(o);
  mapper.start(2);
  std::atomic<bool> done{false};
  std::thread renderer([&] {
    const Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
    // A render about every millisecond. Without the pause the loop took the mapper's lock back
    // the moment it let go, and on a busy machine the loads and the workers waited for it for
    // up to a minute (1.6 s alone).
    while (!done) {
      mapper.render(sidePose(), kf.frame.camera);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  for (int i = 0; i < 6; ++i) {
    mapper.enqueueKeyframe(std::make_shared<Keyframe>(planeKeyframe(10 + i, Eigen::Isometry3d::Identity())), true);
    EXPECT_EQ(mapper.loadPly(ply), saved_count);
    EXPECT_THROW(mapper.loadPly(bad), std::runtime_error);
  }
  mapper.waitUntilIdle();
  done = true;
  renderer.join();
  mapper.stop();
  EXPECT_GE(mapper.stats().num_gaussians, saved_count);
  std::remove(ply.c_str());
  std::remove(bad.c_str());
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
