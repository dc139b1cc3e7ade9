/// GaussianMapper: bad input, capacity, densify/prune invariants, re-anchoring, training on a synthetic sequence (PSNR,
/// no ghosts).
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "dypho/mapping/gaussian_mapper.h"
#include "dypho/mapping/thread_pool.h"
#include "plane_keyframe.h"
#include "dypho/mapping/gaussian_ply.h"
#include "dypho/tools/synthetic_scene.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

std::string tempPath(const std::string& name) {
  return "/tmp/dypho_test_gaussian_" + std::to_string(::getpid()) + "_" + name;
}

/// A textured fronto-parallel plane at 2 m.
Keyframe planeKeyframe(std::int64_t id, const Eigen::Isometry3d& T_world_camera) {
  return test::texturedPlaneKeyframe(id, T_world_camera, 160, 120, 130.0, 10);
}

GaussianMapperOptions smallOptions() { return test::smallMapperOptions(); }

TEST(GaussianMapper, BadKeyframesAreSkippedWithAReason) {
  GaussianMapper mapper(smallOptions());
  Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
  kf.T_world_camera.translation().x() = std::nan("");
  AddKeyframeResult r = mapper.addKeyframe(kf);
  EXPECT_FALSE(r.added);
  EXPECT_NE(r.message.find("not finite"), std::string::npos) << r.message;
  kf = planeKeyframe(2, Eigen::Isometry3d::Identity());
  kf.frame.depth_m.release();
  r = mapper.addKeyframe(kf);
  EXPECT_FALSE(r.added);
  EXPECT_NE(r.message.find("depth image is empty"), std::string::npos) << r.message;
  kf = planeKeyframe(3, Eigen::Isometry3d::Identity());
  kf.frame.depth_m.setTo(0.f);
  r = mapper.addKeyframe(kf);
  EXPECT_FALSE(r.added);
  EXPECT_NE(r.message.find("no static pixel with valid depth"), std::string::npos) << r.message;
  kf = planeKeyframe(4, Eigen::Isometry3d::Identity());
  kf.mask = cv::Mat(10, 10, CV_8UC1, cv::Scalar(0));
  EXPECT_FALSE(mapper.addKeyframe(kf).added);
  EXPECT_EQ(mapper.stats().num_gaussians, 0u);
  EXPECT_EQ(mapper.stats().skipped_keyframes, 4u);
  EXPECT_EQ(mapper.optimize(3), 0.0);  // nothing to train: no crash, no iteration
  EXPECT_THROW(mapper.render(Eigen::Isometry3d::Identity(), CameraIntrinsics()), std::invalid_argument);
}

TEST(GaussianMapper, CapacityIsRespected) {
  GaussianMapperOptions o = smallOptions();
  o.max_gaussians = 50;
  GaussianMapper mapper(o);
  const AddKeyframeResult r = mapper.addKeyframe(planeKeyframe(1, Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(r.added);
  EXPECT_TRUE(r.capacity_reached);
  EXPECT_NE(r.message.find("max_gaussians"), std::string::npos);
  EXPECT_EQ(mapper.stats().num_gaussians, 50u);
  mapper.optimize(5);  // densification at the cap must not grow the map
  EXPECT_LE(mapper.stats().num_gaussians, 50u);
}

TEST(GaussianMapper, TrainingReducesTheLossAndDensifyPruneKeepsInvariants) {
  GaussianMapperOptions o = smallOptions();
  o.densify_interval = 10;
  GaussianMapper mapper(o);
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(1, Eigen::Isometry3d::Identity())).added);
  const double psnr_seeded = mapper.evaluateKeyframes().psnr_db;
  const double first = mapper.optimize(1);
  const double later = mapper.optimize(60);
  EXPECT_LT(later, first);
  const GaussianMapperStats s = mapper.stats();
  EXPECT_EQ(s.iterations, 61);
  EXPECT_GT(s.num_gaussians, 0u);
  EXPECT_LE(s.num_gaussians, o.max_gaussians);
  // After densify/prune every Gaussian is finite and renders finite images.
  for (const GaussianCentre& c : mapper.centres())
    ASSERT_TRUE(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z));
  const RenderedView v =
      mapper.render(Eigen::Isometry3d::Identity(), planeKeyframe(1, Eigen::Isometry3d::Identity()).frame.camera);
  EXPECT_TRUE(cv::checkRange(v.depth_m));
  const KeyframeEvaluation ev = mapper.evaluateKeyframes();
  EXPECT_EQ(ev.num_keyframes, 1u);
  std::printf("plane PSNR: %.2f dB seeded, %.2f dB after 61 iterations\n", psnr_seeded, ev.psnr_db);
  EXPECT_GT(ev.psnr_db, psnr_seeded + 1.0);  // training must improve the rendering clearly (>= 1 dB)
}

TEST(GaussianMapper, TrainingWithTheSsimTermImprovesTheRendering) {
  GaussianMapperOptions o = smallOptions();
  o.ssim_weight = 0.5;
  GaussianMapper mapper(o);
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(1, Eigen::Isometry3d::Identity())).added);
  const double psnr_seeded = mapper.evaluateKeyframes().psnr_db;
  const double first = mapper.optimize(1);
  const double later = mapper.optimize(60);
  EXPECT_LT(later, first);  // the loss includes 0.5 (1 - SSIM)
  const double psnr = mapper.evaluateKeyframes().psnr_db;
  std::printf("plane PSNR with the SSIM term: %.2f dB seeded, %.2f dB after 61 iterations\n", psnr_seeded, psnr);
  EXPECT_GT(psnr, psnr_seeded + 1.0);  // same bound as without the term
}

TEST(GaussianMapper, PoseCorrectionReanchorsTheKeyframesGaussians) {
  GaussianMapper mapper(smallOptions());
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(5, Eigen::Isometry3d::Identity())).added);
  const std::vector<GaussianCentre> before = mapper.centres();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.5, 0, 0);
  EXPECT_TRUE(mapper.updateKeyframePose(5, T));
  EXPECT_FALSE(mapper.updateKeyframePose(6, T));  // unknown id
  Eigen::Isometry3d bad = T;
  bad.translation().y() = std::nan("");
  EXPECT_FALSE(mapper.updateKeyframePose(5, bad));
  const std::vector<GaussianCentre> after = mapper.centres();
  ASSERT_EQ(before.size(), after.size());
  for (std::size_t i = 0; i < after.size(); ++i) {
    EXPECT_NEAR(after[i].x - before[i].x, 0.5f, 1e-5f);
    EXPECT_NEAR(after[i].z, before[i].z, 1e-5f);
  }
}

TEST(GaussianMapper, SavePlyLoadPlyAndPcd) {
  GaussianMapper mapper(smallOptions());
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(1, Eigen::Isometry3d::Identity())).added);
  const std::string ply = tempPath("m.ply"), pcd = tempPath("m.pcd");
  mapper.savePly(ply);
  mapper.saveCentresPcd(pcd);
  GaussianMapper other(smallOptions());
  EXPECT_EQ(other.loadPly(ply), mapper.stats().num_gaussians);
  const Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
  const cv::Mat d1 = mapper.renderDepth(kf.T_world_camera, kf.frame.camera);
  const cv::Mat d2 = other.renderDepth(kf.T_world_camera, kf.frame.camera);
  EXPECT_EQ(cv::norm(d1, d2, cv::NORM_INF), 0.0);  // identical maps render identically
  EXPECT_THROW(mapper.savePly("/nonexistent_dir/map.ply"), std::runtime_error);
  std::remove(ply.c_str());
  std::remove(pcd.c_str());
}

TEST(GaussianMapper, WorkerThreadProcessesQueuedKeyframes) {
  GaussianMapperOptions o = smallOptions();
  o.iterations_per_keyframe = 3;
  GaussianMapper mapper(o);
  std::vector<std::string> messages;
  mapper.setMessageSink([&](const std::string& m) { messages.push_back(m); });
  mapper.start(2);
  for (int i = 0; i < 4; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 0.05 * i;
    mapper.enqueueKeyframe(std::make_shared<Keyframe>(planeKeyframe(i, T)), true);
  }
  Keyframe bad = planeKeyframe(9, Eigen::Isometry3d::Identity());
  bad.frame.bgr.release();
  mapper.enqueueKeyframe(std::make_shared<Keyframe>(bad), true);
  mapper.waitUntilIdle();
  const GaussianMapperStats s = mapper.stats();
  EXPECT_EQ(s.num_keyframes, 4u);
  EXPECT_EQ(s.iterations, 15);  // 3 per keyframe, also for the skipped one (window unchanged)
  EXPECT_EQ(s.skipped_keyframes, 1u);
  ASSERT_EQ(messages.size(), 1u);
  EXPECT_NE(messages[0].find("keyframe 9"), std::string::npos);
  mapper.stop();
}

// Training threads lower themselves to the idle class (training_idle_class, default on): the
// pool's extra threads and the worker do, the caller of the pool keeps its own class. Linux only
// (thread_budget.h); lowering one's own priority needs no privilege, so this holds in CI too.
TEST(GaussianMapper, TrainingThreadsRunInTheIdleClass) {
#ifdef __linux__
  EXPECT_TRUE(GaussianMapperOptions().training_idle_class);
  EXPECT_TRUE(GaussianMapperOptions().trainingPriority().idle_class);
  std::vector<int> idle(2, -1);
  {
    ThreadPool pool(2, GaussianMapperOptions().trainingPriority());
    pool.parallelForStatic(2,
                           [&](int i, int) { idle[static_cast<std::size_t>(i)] = currentThreadIsIdleClass() ? 1 : 0; });
  }
  EXPECT_EQ(idle[0], 0) << "the caller keeps its class";
  EXPECT_EQ(idle[1], 1) << "the pool thread runs in the idle class";
  // 1 when the worker's thread ran its job in the idle class, 0 when not.
  const auto workerIsIdleClass = [](ThreadPriority priority) {
    std::atomic<int> idle_class{-1};
    MappingWorker worker(
        1, [&](const MappingJob&) { idle_class = currentThreadIsIdleClass() ? 1 : 0; }, {}, priority);
    worker.push(MappingJob{}, true);
    worker.waitUntilIdle();
    worker.stop();
    return idle_class.load();
  };
  EXPECT_EQ(workerIsIdleClass(ThreadPriority{10, true}), 1);
  EXPECT_EQ(workerIsIdleClass(ThreadPriority{10, false}), 0) << "off: nice only";
#else
  GTEST_SKIP() << "thread classes are only set on Linux";
#endif
}

// stats() reads counters refreshed after each change: it does not wait for the running training
// iteration (the ROS cloud timer and diagnostics call it beside a training that may hold the
// trainer for a long time at the idle priority).
TEST(GaussianMapper, StatsFollowEveryChange) {
  GaussianMapperOptions o = smallOptions();
  GaussianMapper mapper(o);
  EXPECT_EQ(mapper.stats().num_keyframes, 0u);
  ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(0, Eigen::Isometry3d::Identity())).added);
  GaussianMapperStats s = mapper.stats();
  EXPECT_EQ(s.num_keyframes, 1u);
  EXPECT_GT(s.num_gaussians, 0u);
  EXPECT_EQ(s.num_stored_images, 1u);
  mapper.optimize(2);
  EXPECT_EQ(mapper.stats().iterations, 2);
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.translation().x() = 0.1;
  EXPECT_TRUE(mapper.updateKeyframePose(0, moved));
  EXPECT_EQ(mapper.stats().corrected_keyframes, 1u);
  mapper.reset();
  s = mapper.stats();
  EXPECT_EQ(s.num_keyframes, 0u);
  EXPECT_EQ(s.num_gaussians, 0u);
  EXPECT_EQ(s.iterations, 2) << "a counter over the mapper's life";
}

// Live policy, mapping far behind: a burst of keyframes into a queue of 2 jobs. Every keyframe
// reaches the map (merged jobs seed all theirs), and a correction that arrived between them is
// applied after the keyframe it names was seeded, so that keyframe ends at its corrected pose.
TEST(GaussianMapper, LivePolicyMergesJobsAndLosesNoKeyframe) {
  GaussianMapperOptions o = smallOptions();
  o.iterations_per_keyframe = 10;  // a merged job of K keyframes trains up to 10 K (the sanitized run's time)
  o.live_min_iterations_per_keyframe = 5;
  o.live_train_when_idle = false;
  GaussianMapper mapper(o);
  mapper.start(2, /*live=*/true);
  const auto poseAt = [](double x) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = x;
    return T;
  };
  constexpr int kKeyframes = 12;
  Eigen::Isometry3d corrected = poseAt(0.5);
  for (int i = 0; i < kKeyframes; ++i) {  // pushed within microseconds, an iteration takes milliseconds
    mapper.enqueueKeyframe(std::make_shared<Keyframe>(planeKeyframe(i, poseAt(0.02 * i))), false);
    if (i == 7) mapper.enqueueCorrections({{6, corrected}}, false);
  }
  mapper.waitUntilIdle();
  const GaussianMapperStats s = mapper.stats();
  EXPECT_EQ(s.num_keyframes, static_cast<std::size_t>(kKeyframes)) << "no keyframe may be lost";
  EXPECT_GT(s.merged_jobs, 0u) << "the burst overflowed a queue of 2: jobs must have been merged";
  bool found = false;
  for (const auto& [id, T] : mapper.keyframePoses()) {
    if (id != 6) continue;
    found = true;
    EXPECT_NEAR(T.translation().x(), 0.5, 1e-9) << "the correction must win over the keyframe's own pose";
  }
  EXPECT_TRUE(found);
  // Fewer iterations than 10 per keyframe: only training waited.
  EXPECT_LT(s.iterations, 10 * kKeyframes);
  mapper.stop();
}

// Live policy: when the next job already waits, a keyframe gets live_min_iterations_per_keyframe
// iterations instead of iterations_per_keyframe, so the queue never grows.
TEST(GaussianMapper, LivePolicyCutsIterationsWhenTheNextJobWaits) {
  GaussianMapperOptions o = smallOptions();
  o.iterations_per_keyframe = 30;
  o.live_min_iterations_per_keyframe = 5;
  o.live_train_when_idle = false;
  GaussianMapper mapper(o);
  mapper.start(8, /*live=*/true);
  for (int i = 0; i < 4; ++i) {  // pushed within microseconds: jobs 2-4 wait while job 1 trains
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 0.05 * i;
    mapper.enqueueKeyframe(std::make_shared<Keyframe>(planeKeyframe(i, T)), false);
  }
  mapper.waitUntilIdle();
  const GaussianMapperStats s = mapper.stats();
  EXPECT_EQ(s.num_keyframes, 4u);
  EXPECT_EQ(s.merged_jobs, 0u);
  // 5 + 5 + 5 + 30 (the last one has nothing behind it). Upper bound below the 4 x 30 of the
  // deterministic policy; the exact count holds unless the pushing thread stalls for longer than
  // 5 iterations between two pushes, hence a range.
  EXPECT_GE(s.iterations, 45);
  EXPECT_LT(s.iterations, 4 * 30);
  mapper.stop();
}

// Live policy: with no job waiting the worker keeps training; finish() pauses that idle training
// and runs its own refinement.
TEST(GaussianMapper, LivePolicyTrainsWhileIdle) {
  GaussianMapperOptions o = smallOptions();
  o.iterations_per_keyframe = 3;
  o.final_refine_iterations = 4;
  GaussianMapper mapper(o);
  mapper.start(8, /*live=*/true);
  mapper.enqueueKeyframe(std::make_shared<Keyframe>(planeKeyframe(0, Eigen::Isometry3d::Identity())), false);
  mapper.waitUntilIdle();
  // Idle iterations follow; wait (at most 20 s, a loaded CI machine) for 20 beyond the keyframe's 3.
  const auto start = std::chrono::steady_clock::now();
  while (mapper.stats().iterations < 3 + 20 && std::chrono::steady_clock::now() - start < std::chrono::seconds(20)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_GE(mapper.stats().iterations, 3 + 20) << "no training while idle";
  EXPECT_EQ(mapper.stats().num_keyframes, 1u);
  EXPECT_GT(mapper.latestSnapshot().iterations, 3) << "the renders follow the idle training";
  mapper.finish();
  mapper.stop();
}

// Live policy on the CPU: live_cpu_training_duty d makes the worker rest t (1 - d) / d after an
// iteration of t seconds. The same idle training for the same wall time, d = 1 against d = 0.25:
// the second runs a quarter of the iterations in theory; bound: under half (iteration times vary
// on a loaded machine), and at least one.
TEST(GaussianMapper, LiveCpuTrainingRestsForItsDuty) {
  auto idleIterations = [](double duty) {
    GaussianMapperOptions o = smallOptions();
    o.device = "cpu";
    o.iterations_per_keyframe = 1;
    o.live_cpu_training_duty = duty;
    GaussianMapper mapper(o);
    mapper.start(8, /*live=*/true);
    mapper.enqueueKeyframe(std::make_shared<Keyframe>(planeKeyframe(0, Eigen::Isometry3d::Identity())), false);
    mapper.waitUntilIdle();
    const std::int64_t before = mapper.stats().iterations;
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    const std::int64_t during = mapper.stats().iterations - before;
    mapper.stop();
    return during;
  };
  const std::int64_t full = idleIterations(1.0);
  const std::int64_t quarter = idleIterations(0.25);
  std::cout << "idle iterations in 1.5 s: " << full << " at duty 1, " << quarter << " at duty 0.25\n";
  EXPECT_GE(full, 8) << "too few iterations to compare";
  EXPECT_GE(quarter, 1) << "the worker must still train";
  EXPECT_LT(2 * quarter, full) << "duty 0.25: " << quarter << " iterations against " << full << " at duty 1";
}

// The deterministic policy (offline runner) never trains while idle.
TEST(GaussianMapper, DeterministicPolicyDoesNotTrainWhileIdle) {
  GaussianMapperOptions o = smallOptions();
  o.iterations_per_keyframe = 3;
  GaussianMapper mapper(o);
  mapper.start(8);
  mapper.enqueueKeyframe(std::make_shared<Keyframe>(planeKeyframe(0, Eigen::Isometry3d::Identity())), true);
  mapper.waitUntilIdle();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(mapper.stats().iterations, 3);
  mapper.stop();
}

TEST(GaussianMapper, FinishRunsTheFinalRefinementOverAllKeyframes) {
  GaussianMapperOptions o = smallOptions();
  o.final_refine_iterations = 7;
  o.window_size = 1;
  GaussianMapper mapper(o);
  for (int i = 0; i < 3; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 0.1 * i;
    ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(i, T)).added);
  }
  mapper.optimize(2);
  mapper.finish();
  EXPECT_EQ(mapper.stats().iterations, 2 + 7);
  // finish() returns the mean loss of its refinement iterations: with one, that iteration's loss.
  o.final_refine_iterations = 1;
  GaussianMapper one(o);
  ASSERT_TRUE(one.addKeyframe(planeKeyframe(0, Eigen::Isometry3d::Identity())).added);
  const double loss = one.finish();
  EXPECT_EQ(one.stats().iterations, 1);
  EXPECT_EQ(loss, one.stats().last_loss);
  EXPECT_GT(loss, 0.0);
  GaussianMapper empty(o);
  EXPECT_EQ(empty.finish(), 0.0);  // nothing to refine: no iteration, no crash
  EXPECT_EQ(empty.stats().iterations, 0);
}

// The evaluation at shutdown has a time budget (mapping nodelet ~shutdown_evaluation_budget_s):
// past it no keyframe is rendered, every stored one is still counted; within it the result is
// the unbounded one, per keyframe in keyframe order.
TEST(GaussianMapper, EvaluationStopsAtItsBudgetAndCountsTheStoredKeyframes) {
  GaussianMapper mapper(smallOptions());
  for (int i = 0; i < 5; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 0.05 * i;
    ASSERT_TRUE(mapper.addKeyframe(planeKeyframe(i, T)).added);
  }
  mapper.optimize(3);
  const KeyframeEvaluation all = mapper.evaluateKeyframes();
  EXPECT_EQ(all.num_keyframes, 5u);
  EXPECT_EQ(all.num_keyframes_stored, 5u);
  ASSERT_EQ(all.psnr_per_keyframe_db.size(), 5u);
  const KeyframeEvaluation none = mapper.evaluateKeyframes("", 0.0);  // the budget is spent at once
  EXPECT_EQ(none.num_keyframes, 0u);
  EXPECT_EQ(none.num_keyframes_stored, 5u);
  const KeyframeEvaluation ample = mapper.evaluateKeyframes("", 3600.0);
  ASSERT_EQ(ample.psnr_per_keyframe_db.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(ample.psnr_per_keyframe_db[i], all.psnr_per_keyframe_db[i]) << i;
  EXPECT_EQ(ample.psnr_db, all.psnr_db);
}

TEST(GaussianMapper, StaticPixelsWithoutDepthAreCoveredAtTheNeighbouringDepth) {
  // A 40x30 px hole without depth (a black screen for the depth camera) in the textured plane.
  Keyframe kf = planeKeyframe(1, Eigen::Isometry3d::Identity());
  kf.frame.depth_m(cv::Rect(60, 45, 40, 30)).setTo(0.f);
  GaussianMapperOptions o = smallOptions();
  o.coverage_fill_invalid_depth = false;
  GaussianMapper without(o);
  ASSERT_TRUE(without.addKeyframe(kf).added);
  o.coverage_fill_invalid_depth = true;
  GaussianMapper with(o);
  ASSERT_TRUE(with.addKeyframe(kf).added);
  EXPECT_GT(with.stats().num_gaussians, without.stats().num_gaussians);
  const RenderedView a = without.render(kf.T_world_camera, kf.frame.camera);
  const RenderedView b = with.render(kf.T_world_camera, kf.frame.camera);
  // Centre of the hole: nothing rendered without the fill; with it, an opaque surface at the
  // plane's depth (the filled nodes take the 2 m of their neighbours; 1 cm = float rounding).
  EXPECT_LT(a.alpha.at<float>(60, 80), 0.05f);
  EXPECT_GT(b.alpha.at<float>(60, 80), 0.5f);
  EXPECT_NEAR(b.depth_m.at<float>(60, 80), 2.f, 0.01f);
}

TEST(GaussianMapper, ExposureCompensationFollowsABrightnessChange) {
  // Two views of the same plane; the second image is 30 % darker (auto exposure). With the
  // per-keyframe exposure the map keeps one colour and keyframe 2's gain absorbs the change.
  auto run = [](bool compensate) {
    GaussianMapperOptions o = smallOptions();
    o.exposure_compensation = compensate;
    o.window_size = 2;
    GaussianMapper mapper(o);
    Keyframe a = planeKeyframe(1, Eigen::Isometry3d::Identity());
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 0.05;
    Keyframe b = planeKeyframe(2, T);
    b.frame.bgr.convertTo(b.frame.bgr, CV_8UC3, 0.7);
    EXPECT_TRUE(mapper.addKeyframe(a).added);
    EXPECT_TRUE(mapper.addKeyframe(b).added);
    mapper.optimize(150);
    return mapper.evaluateKeyframes();
  };
  const KeyframeEvaluation off = run(false), on = run(true);
  std::printf("exposure: PSNR %.2f dB without compensation, %.2f dB with (%.2f dB plain render)\n", off.psnr_db,
              on.psnr_db, on.psnr_without_exposure_db);
  EXPECT_EQ(off.psnr_db, off.psnr_without_exposure_db);  // off: the evaluation is the plain render
  // One map cannot match both brightnesses without the exposure; with it clearly better
  // (measured +2.15 dB after 150 iterations; the bound asks for half of that).
  EXPECT_GT(on.psnr_db, off.psnr_db + 1.0);
}

/// Synthetic room with two walking people, ground-truth poses and masks: static PSNR and the
/// ghost check (rendered depth where people are stays at the static depth).
TEST(GaussianMapper, SyntheticSequenceHasNoGhosts) {
  tools::SynthOptions so;
  so.frames = 100;
  so.people = 2;
  so.seed = 3;
  tools::SyntheticScene scene(so);
  GaussianMapperOptions o;
  GaussianMapper mapper(o);
  std::vector<int> kfs;
  for (int i = 0; i < so.frames; i += 10) {
    const tools::SynthFrame f = scene.render(i);
    Keyframe kf;
    kf.id = i;
    kf.frame = f.frame;
    kf.mask = f.mask_gt;
    kf.T_world_camera = f.T_world_camera;
    // Keypoints as tracking hands them over: corners on static pixels, with depth.
    cv::Mat gray;
    cv::cvtColor(f.frame.bgr, gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(gray, corners, 500, 0.01, 8, f.mask_gt == 0);
    for (const auto& c : corners) {
      KeyframeKeypoint k;
      k.u_px = c.x;
      k.v_px = c.y;
      k.depth_m = f.frame.depth_m.at<float>(cvRound(c.y), cvRound(c.x));
      kf.keypoints.push_back(k);
    }
    ASSERT_TRUE(mapper.addKeyframe(kf).added);
    mapper.optimize(o.iterations_per_keyframe);
    kfs.push_back(i);
  }
  // "Where people passed": pixels a person covers in keyframe k whose static surface is seen
  // (static, matching depth within 5 cm) in another keyframe. Never-seen background has no
  // reference and is not counted.
  std::vector<tools::SynthFrame> frames;
  for (int i : kfs) frames.push_back(scene.render(i));
  const CameraIntrinsics& cam = frames[0].frame.camera;
  auto seenElsewhere = [&](std::size_t k, int x, int y) {
    const float z = frames[k].static_depth_m.at<float>(y, x);
    const Eigen::Vector3d p_w =
        frames[k].T_world_camera * Eigen::Vector3d((x - cam.cx) / cam.fx * z, (y - cam.cy) / cam.fy * z, z);
    for (std::size_t j = 0; j < frames.size(); ++j) {
      if (j == k) continue;
      const Eigen::Vector3d p = frames[j].T_world_camera.inverse() * p_w;
      if (p.z() <= 0.1) continue;
      const int u = static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx));
      const int v = static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy));
      if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
      if (frames[j].mask_gt.at<std::uint8_t>(v, u) == 0 &&
          std::abs(frames[j].frame.depth_m.at<float>(v, u) - p.z()) < 0.05)
        return true;
    }
    return false;
  };
  mapper.finish();  // the final map: end-of-sequence refinement (final_refine_iterations)
  std::size_t n = 0, ok = 0, closer = 0, farther = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const tools::SynthFrame& f = frames[k];
    const cv::Mat d = mapper.renderDepth(f.T_world_camera, f.frame.camera);
    for (int y = 0; y < d.rows; y += 2)
      for (int x = 0; x < d.cols; x += 2) {
        if (!f.mask_gt.at<std::uint8_t>(y, x) || !seenElsewhere(k, x, y)) continue;
        ++n;
        const float err = d.at<float>(y, x) - f.static_depth_m.at<float>(y, x);
        ok += std::abs(err) <= 0.05f;
        closer += err < -0.05f;  // a ghost: something rendered in front of the static surface
        farther += err > 0.05f;  // seen through: the static surface is not opaque from here
      }
  }
  std::printf(
      "ghost check: %.2f %% of %zu revealed dynamic pixels within 5 cm (%.2f %% closer: ghosts, %.2f %% farther)\n",
      100.0 * ok / std::max<std::size_t>(1, n), n, 100.0 * closer / std::max<std::size_t>(1, n),
      100.0 * farther / std::max<std::size_t>(1, n));
  ASSERT_GT(n, 1000u);
  const double share = static_cast<double>(ok) / n;
  // The target: >= 99 % within 5 cm. Measured 99.46-99.51 % (0.00 % closer, 0.5 % farther:
  // background seen only from other viewpoints, rendered through gaps) with the final refinement
  // and coverage_alpha_threshold 0.9 (97.0 % before both). Ghosts proper (rendered > 5 cm in
  // front of the static surface): <= 0.5 % (measured 0.00 %). The sampler is seeded; only the
  // thread scheduling of float sums varies between runs (four runs: 99.46-99.51 %).
  EXPECT_GE(share, 0.99);
  EXPECT_LE(static_cast<double>(closer) / n, 0.005);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
