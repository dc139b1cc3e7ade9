/// The in-process pipeline on a short synthetic sequence: repeatable to the bit with R_d in use,
/// corrections reach the map, and the shared constant-velocity model's reset rules.

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/common/motion_prior.h"
#include "dypho/common/stamp_gate.h"
#include "dypho/pipeline/slam_pipeline.h"
#include "dypho/tools/synthetic_scene.h"

namespace {

using namespace dypho;

Eigen::Isometry3d poseAt(double x_m, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, 0.0, 0.0);
  return T;
}

constexpr Timestamp kFrameNs = 33'333'333;  // 30 Hz

TEST(ConstantVelocityModel, PredictsScaledByTime) {
  ConstantVelocityModel model;
  model.observe({0, poseAt(0.0, 0.0), true, false});
  EXPECT_FALSE(model.predict(kFrameNs).has_value());  // one pose: no velocity yet
  model.observe({kFrameNs, poseAt(0.01, 0.02), true, false});
  // The step from frame 0 to 1 is poseAt(0.01, 0.02); the next one repeats it.
  const auto next = model.predict(2 * kFrameNs);
  ASSERT_TRUE(next.has_value());
  const Eigen::Isometry3d step = poseAt(0.01, 0.02);
  EXPECT_TRUE(next->isApprox(step * step, 1e-9)) << next->matrix();
  // A dropped frame: two intervals ahead the step is doubled (twice the translation and angle).
  const auto skip = model.predict(3 * kFrameNs);
  ASSERT_TRUE(skip.has_value());
  EXPECT_TRUE(skip->isApprox(step * poseAt(0.02, 0.04), 1e-9)) << skip->matrix();
}

TEST(ConstantVelocityModel, ResetRules) {
  ConstantVelocityModel model(1.0);
  model.observe({0, poseAt(0.0, 0.0), true, false});
  model.observe({kFrameNs, poseAt(0.01, 0.0), true, false});
  ASSERT_TRUE(model.hasVelocity());
  // A jump (loop closure, relocalisation): the new pose is kept, no velocity across the jump.
  model.observe({2 * kFrameNs, poseAt(5.0, 0.0), true, true});
  EXPECT_FALSE(model.hasVelocity());
  EXPECT_FALSE(model.predict(3 * kFrameNs).has_value());
  ASSERT_TRUE(model.last().has_value());
  EXPECT_NEAR(model.last()->translation().x(), 5.0, 1e-12);
  model.observe({3 * kFrameNs, poseAt(5.01, 0.0), true, false});
  EXPECT_TRUE(model.hasVelocity());
  // Lost: everything is forgotten.
  model.observe({4 * kFrameNs, poseAt(0.0, 0.0), false, false});
  EXPECT_FALSE(model.last().has_value());
  // Time going backwards starts over from that pose.
  model.observe({10 * kFrameNs, poseAt(1.0, 0.0), true, false});
  model.observe({11 * kFrameNs, poseAt(1.01, 0.0), true, false});
  model.observe({5 * kFrameNs, poseAt(2.0, 0.0), true, false});
  EXPECT_FALSE(model.hasVelocity());
  // A gap over max_gap_s is a jump.
  model.observe({5 * kFrameNs + 2'000'000'000, poseAt(2.01, 0.0), true, false});
  EXPECT_FALSE(model.hasVelocity());
}

// A correction of the earlier poses (a local BA applied late) is applied to the last pose before
// the step is formed: the velocity stays the camera's motion, not the correction.
TEST(ConstantVelocityModel, CorrectionOfTheEarlierPosesIsNotMotion) {
  ConstantVelocityModel model;
  model.observe({0, poseAt(0.0, 0.0), true, false});
  model.observe({kFrameNs, poseAt(0.01, 0.0), true, false});
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  correction.translation() << 0.0, 0.05, 0.0;  // the world moved 5 cm under frames 0 and 1
  PoseUpdate update{2 * kFrameNs, correction * poseAt(0.02, 0.0), true, false};
  update.T_correction = correction;
  model.observe(update);
  ASSERT_TRUE(model.lastStep().has_value());
  EXPECT_TRUE(model.lastStep()->isApprox(poseAt(0.01, 0.0), 1e-9)) << model.lastStep()->matrix();
  // Without it, the 5 cm would have become velocity.
  ConstantVelocityModel uncorrected;
  uncorrected.observe({0, poseAt(0.0, 0.0), true, false});
  uncorrected.observe({kFrameNs, poseAt(0.01, 0.0), true, false});
  uncorrected.observe({2 * kFrameNs, correction * poseAt(0.02, 0.0), true, false});
  EXPECT_GT((uncorrected.lastStep()->translation() - poseAt(0.01, 0.0).translation()).norm(), 0.04);
}

struct RunResult {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::int64_t> keyframes;
  std::size_t frames_with_rendered_depth = 0;
  std::size_t correction_batches = 0;
  std::size_t corrected_in_mapper = 0;
  KeyframePoseCorrections tracker_keyframes;  ///< final keyframe poses of the tracker
  KeyframePoseCorrections mapper_keyframes;   ///< keyframe poses the Gaussian map is anchored to
};

RunResult runSynthetic(int frames, bool loop_closure) {
  tools::SynthOptions so;
  so.frames = frames;
  so.people = 2;
  so.seed = 3;
  const tools::SyntheticScene scene(so);
  pipeline::PipelineOptions options;
  options.tracking.loop_closure = loop_closure;
  options.mask.background.tau = 0.1;  // R_d on (the paper's weight; off by default)
  options.mapping.gaussian.iterations_per_keyframe = 10;  // keeps the test short; R_d needs a map only
  options.mapping.gaussian.final_refine_iterations = 0;
  pipeline::SlamPipeline slam(options);
  RunResult r;
  for (int i = 0; i < frames; ++i) {
    const pipeline::FrameReport report = slam.process(scene.render(i).frame);
    r.poses.push_back(report.tracking.T_world_camera);
    if (report.tracking.is_keyframe) r.keyframes.push_back(report.tracking.keyframe->id);
  }
  slam.mapping().gaussians().waitUntilIdle();
  r.frames_with_rendered_depth = slam.mask().stats().frames_with_rendered_depth;
  const mapping::MappingStageStats stats = slam.mapping().stats();
  r.correction_batches = stats.correction_batches;
  r.corrected_in_mapper = stats.gaussians.corrected_keyframes;
  for (const auto& [id, kf] : slam.tracking().odometry().map().keyframes()) r.tracker_keyframes.emplace_back(id, kf.T_world_camera);
  r.mapper_keyframes = slam.mapping().gaussians().keyframePoses();
  return r;
}

// Two runs of the same frames give the same bits (the R_d render comes from the map as it stood
// after the previous keyframe's job, and training reduces in a fixed order), with R_d in use.
TEST(SlamPipeline, RepeatableToTheBitWithRenderedDepth) {
  const RunResult a = runSynthetic(60, true);
  const RunResult b = runSynthetic(60, true);
  ASSERT_EQ(a.poses.size(), b.poses.size());
  EXPECT_EQ(a.keyframes, b.keyframes);
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    ASSERT_TRUE(a.poses[i].matrix() == b.poses[i].matrix()) << "frame " << i;
  }
  // R_d needs a snapshot after the second keyframe's predecessor: most later frames use it.
  ASSERT_GE(a.keyframes.size(), 3u);
  EXPECT_GT(a.frames_with_rendered_depth, 20u) << "of 60 frames";
  EXPECT_EQ(a.frames_with_rendered_depth, b.frames_with_rendered_depth);
}

// Local BA moves earlier keyframes; without loop closure the only source of corrections is local
// BA. Every such correction reaches the Gaussian map: its keyframe poses equal the tracker's.
TEST(SlamPipeline, LocalBaCorrectionsReachTheGaussianMap) {
  const RunResult r = runSynthetic(90, /*loop_closure=*/false);
  EXPECT_GT(r.correction_batches, 0u);
  EXPECT_GT(r.corrected_in_mapper, 0u);
  ASSERT_FALSE(r.mapper_keyframes.empty());
  for (const auto& [id, T_mapper] : r.mapper_keyframes) {
    const auto it = std::find_if(r.tracker_keyframes.begin(), r.tracker_keyframes.end(),
                                 [&](const auto& kf) { return kf.first == id; });
    ASSERT_NE(it, r.tracker_keyframes.end()) << "keyframe " << id;
    // Bound: the correction threshold (1 mm, 0.001 rad) is the largest difference left unsent.
    EXPECT_LT((T_mapper.translation() - it->second.translation()).norm(), 1e-3 + 1e-9) << "keyframe " << id;
    EXPECT_LT(Eigen::AngleAxisd(T_mapper.rotation().transpose() * it->second.rotation()).angle(), 1e-3 + 1e-9)
        << "keyframe " << id;
  }
}

}  // namespace

namespace {

TEST(StampGate, DropsRepeatedAndLateFramesRestartsOnAJumpBack) {
  StampGate gate(1.0);
  EXPECT_EQ(gate.admit(10 * kFrameNs), StampOrder::kNext);
  EXPECT_EQ(gate.admit(11 * kFrameNs), StampOrder::kNext);
  EXPECT_EQ(gate.admit(11 * kFrameNs), StampOrder::kRepeated);
  EXPECT_EQ(gate.admit(9 * kFrameNs), StampOrder::kLate);    // 2 frames late
  EXPECT_EQ(gate.admit(12 * kFrameNs), StampOrder::kNext);   // the newest stays 11, then 12
  EXPECT_EQ(gate.admit(12 * kFrameNs - 1'000'000'000), StampOrder::kLate);  // exactly 1 s: late
  EXPECT_EQ(gate.dropped(), 3u);
  EXPECT_EQ(gate.restarts(), 0u);
  EXPECT_EQ(gate.admit(12 * kFrameNs - 1'000'000'001), StampOrder::kJumpedBack);
  EXPECT_EQ(gate.restarts(), 1u);
  // After the jump the new run's stamps are the reference.
  EXPECT_EQ(gate.admit(12 * kFrameNs - 1'000'000'001 + kFrameNs), StampOrder::kNext);
  // Extreme stamps do not overflow the comparison.
  StampGate extremes;
  EXPECT_EQ(extremes.admit(std::numeric_limits<Timestamp>::max()), StampOrder::kNext);
  EXPECT_EQ(extremes.admit(std::numeric_limits<Timestamp>::min()), StampOrder::kJumpedBack);
}

// Through the whole pipeline: a repeated and a late frame are dropped (no pose, no restart, the
// trajectory keeps its frames); a looped sequence (time back by 5 s) restarts tracking.
TEST(SlamPipeline, DropsRepeatedAndLateFramesRestartsWhenTimeJumpsBack) {
  tools::SynthOptions so;
  so.frames = 40;
  so.people = 1;
  so.seed = 5;
  const tools::SyntheticScene scene(so);
  pipeline::PipelineOptions options;
  options.mapping.gaussian.iterations_per_keyframe = 2;
  options.mapping.gaussian.final_refine_iterations = 0;
  pipeline::SlamPipeline slam(options);
  std::vector<tools::SynthFrame> frames;
  for (int i = 0; i < 30; ++i) frames.push_back(scene.render(i));
  for (int i = 0; i < 20; ++i) ASSERT_FALSE(slam.process(frames[i].frame).dropped) << "frame " << i;
  const std::size_t recorded = slam.tracking().numFrames();
  ASSERT_EQ(recorded, 20u);

  RgbdFrame repeated = frames[20].frame;  // new content, the previous frame's stamp
  repeated.stamp_ns = frames[19].frame.stamp_ns;
  const pipeline::FrameReport r1 = slam.process(repeated);
  EXPECT_TRUE(r1.dropped);
  EXPECT_NE(r1.message.find("repeated"), std::string::npos) << r1.message;
  const pipeline::FrameReport r2 = slam.process(frames[15].frame);  // 5 frames late
  EXPECT_TRUE(r2.dropped);
  EXPECT_NE(r2.message.find("out of order"), std::string::npos) << r2.message;
  EXPECT_EQ(slam.tracking().numFrames(), recorded) << "a dropped frame must not enter the trajectory";
  EXPECT_EQ(slam.mask().stats().dropped_out_of_order, 2u);
  EXPECT_EQ(slam.mask().stats().restarts, 0u);

  // Tracking goes on where it was: the next frames are tracked, not re-initialised.
  for (int i = 20; i < 25; ++i) {
    const pipeline::FrameReport r = slam.process(frames[i].frame);
    EXPECT_FALSE(r.dropped);
    EXPECT_FALSE(r.tracking.discontinuous) << "frame " << i;
    EXPECT_EQ(r.tracking.state, tracking::TrackingState::kOk) << "frame " << i;
  }
  EXPECT_EQ(slam.tracking().numFrames(), recorded + 5);

  // A jump back by more than 1 s (the sequence looped): a new run.
  RgbdFrame looped = frames[0].frame;
  looped.stamp_ns = frames[24].frame.stamp_ns - 5'000'000'000;
  const pipeline::FrameReport r3 = slam.process(looped);
  EXPECT_FALSE(r3.dropped);
  EXPECT_EQ(slam.mask().stats().restarts, 1u);
  // The frame that jumped back resets the tracker and has no pose (the next frame starts the new
  // world), so the trajectory is cleared and restarts with the next frame.
  EXPECT_EQ(slam.tracking().numFrames(), 0u) << "the trajectory restarts with the new run";
  RgbdFrame next = frames[1].frame;
  next.stamp_ns = looped.stamp_ns + (frames[1].frame.stamp_ns - frames[0].frame.stamp_ns);
  EXPECT_EQ(slam.process(next).tracking.state, tracking::TrackingState::kOk);
  EXPECT_EQ(slam.tracking().numFrames(), 1u);
}

}  // namespace
