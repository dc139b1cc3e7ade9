/// The in-process pipeline on a short synthetic sequence: repeatable to the bit with R_d in use,
/// corrections reach the map, stamps out of order are dropped or restart tracking.

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/pipeline/realtime_runner.h"
#include "dypho/pipeline/slam_pipeline.h"
#include "dypho/tools/synthetic_scene.h"

namespace DYPHO_UNITY_ID {

using namespace dypho;

struct RunResult {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::int64_t> keyframes;
  std::size_t frames_with_rendered_depth = 0;
  std::size_t correction_batches = 0;
  std::size_t corrected_in_mapper = 0;
  KeyframePoseCorrections tracker_keyframes;  ///< final keyframe poses of the tracker
  KeyframePoseCorrections mapper_keyframes;   ///< keyframe poses the Gaussian map is anchored to
  std::size_t adopted_map_poses = 0;          ///< adoptMapKeyframePoses() at the end
};

/// R_d's weight in the paper (MaskOptions background.tau; off by default).
constexpr double kPaperRenderedDepthTau = 0.1;

/// `rendered_depth`: R_d on (kPaperRenderedDepthTau), which needs the map's render at every
/// frame's predicted pose. `iterations_per_keyframe`: the map's training per keyframe, kept short
/// (the tests check poses and bits, not the map's quality).
RunResult runSynthetic(int frames, bool loop_closure, bool rendered_depth, int iterations_per_keyframe) {
  tools::SynthOptions so;
  so.frames = frames;
  so.people = 2;
  so.seed = 3;
  const tools::SyntheticScene scene(so);
  pipeline::PipelineOptions options;
  options.tracking.loop_closure = loop_closure;
  if (rendered_depth) options.mask.background.tau = kPaperRenderedDepthTau;
  options.mapping.gaussian.iterations_per_keyframe = iterations_per_keyframe;
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
  for (const auto& [id, kf] : slam.tracking().odometry().map().keyframes())
    r.tracker_keyframes.emplace_back(id, kf.T_world_camera);
  r.mapper_keyframes = slam.mapping().gaussians().keyframePoses();
  r.adopted_map_poses = slam.adoptMapKeyframePoses();
  return r;
}

// Two runs of the same frames give the same bits (the R_d render comes from the map as it stood
// after the previous keyframe's job, and training reduces in a fixed order), with R_d in use.
TEST(SlamPipeline, RepeatableToTheBitWithRenderedDepth) {
  // Ten iterations per keyframe: the training's reductions must be repeatable too.
  const RunResult a = runSynthetic(60, /*loop_closure=*/true, /*rendered_depth=*/true, 10);
  const RunResult b = runSynthetic(60, /*loop_closure=*/true, /*rendered_depth=*/true, 10);
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
  // Two iterations per keyframe: training runs beside the corrections (they re-anchor Gaussians
  // that training moves), which is all this test needs of it; the rasterizer was 43 % of the
  // test's time with ten under ASan.
  const RunResult r = runSynthetic(90, /*loop_closure=*/false, /*rendered_depth=*/false, 2);
  EXPECT_GT(r.correction_batches, 0u);
  EXPECT_GT(r.corrected_in_mapper, 0u);
  ASSERT_FALSE(r.mapper_keyframes.empty());
  // Without the map's pose refinement (off by default) no keyframe pose comes back from the map.
  EXPECT_EQ(r.adopted_map_poses, 0u);
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

}  // namespace DYPHO_UNITY_ID

namespace DYPHO_UNITY_ID {

// Through the whole pipeline: a repeated and a late frame are dropped (no pose, no restart, the
// trajectory keeps its frames); a looped sequence (time back by 5 s) restarts tracking. With R_d
// in use: the mask renders the map at the predicted pose until the restart, and goes on after it.
TEST(SlamPipeline, DropsRepeatedAndLateFramesRestartsWhenTimeJumpsBack) {
  tools::SynthOptions so;
  so.frames = 40;
  so.people = 1;
  so.seed = 5;
  const tools::SyntheticScene scene(so);
  pipeline::PipelineOptions options;
  options.mask.background.tau = kPaperRenderedDepthTau;  // R_d on
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
  EXPECT_GT(slam.mask().stats().frames_with_rendered_depth, 0u) << "R_d was never used";

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

}  // namespace DYPHO_UNITY_ID

namespace DYPHO_UNITY_ID {

// pose_refinement: at the end the map's refined keyframe poses become the tracker's, and the
// final trajectory follows them (with it off nothing is handed back: checked at the end of
// SlamPipeline.LocalBaCorrectionsReachTheGaussianMap, a run with the default options).
TEST(SlamPipeline, RefinedKeyframePosesGoBackToTracking) {
  tools::SynthOptions so;
  so.frames = 30;
  so.people = 1;
  so.seed = 4;
  const tools::SyntheticScene scene(so);
  pipeline::PipelineOptions options;
  options.mapping.gaussian.iterations_per_keyframe = 10;
  options.mapping.gaussian.final_refine_iterations = 30;
  options.mapping.gaussian.pose_refinement = true;
  const auto on = std::make_unique<pipeline::SlamPipeline>(options);
  for (int i = 0; i < so.frames; ++i) on->process(scene.render(i).frame);
  on->finishTracking();
  const tracking::PoseList before = on->tracking().finalTrajectory();
  const std::size_t adopted = on->adoptMapKeyframePoses();
  const KeyframePoseCorrections mapper = on->mapping().gaussians().keyframePoses();
  ASSERT_GE(mapper.size(), 2u);
  EXPECT_EQ(adopted, mapper.size()) << "every keyframe of the map is one of the tracker's here";
  for (const auto& [id, T_map] : mapper) {
    const tracking::MapKeyframe* kf = on->tracking().odometry().map().keyframe(id);
    ASSERT_NE(kf, nullptr) << "keyframe " << id;
    EXPECT_TRUE(kf->T_world_camera.isApprox(T_map, 1e-12)) << "keyframe " << id;
  }
  const tracking::PoseList after = on->tracking().finalTrajectory();
  ASSERT_EQ(before.size(), after.size());
  double moved_m = 0.0;
  for (std::size_t i = 0; i < after.size(); ++i)
    moved_m = std::max(moved_m, (after[i].second.translation() - before[i].second.translation()).norm());
  EXPECT_GT(moved_m, 0.0) << "the trajectory follows the refined keyframes";
  // The refinement's bound (5 cm, 2 deg) plus 2 deg over a frame's distance to its keyframe
  // (under 0.3 m here: 1 cm).
  EXPECT_LT(moved_m, 0.06);
}

}  // namespace DYPHO_UNITY_ID

namespace DYPHO_UNITY_ID {

// PipelineOptions::mask_poses_one_frame_late: the mask stage gets each pose after it masked the
// next frame, so no mask has a fresh prediction (the live graph's stale case), every mask after
// the first poses has one from the pose one frame before the previous frame's, the stage never waits (the 33 ms wait
// would time out on every frame), and tracking still poses every frame. Without it every frame after the first two has
// a fresh one.
TEST(SlamPipeline, MaskPosesOneFrameLateGiveEveryMaskAStalePrediction) {
  tools::SynthOptions so;
  so.frames = 30;
  so.people = 1;
  so.seed = 5;
  const tools::SyntheticScene scene(so);
  for (const bool late : {false, true}) {
    pipeline::PipelineOptions options;
    options.build_map = false;
    options.mask_poses_one_frame_late = late;
    pipeline::SlamPipeline slam(options);
    int posed = 0;
    for (int i = 0; i < so.frames; ++i) {
      const pipeline::FrameReport report = slam.process(scene.render(i).frame);
      if (report.tracking.state == tracking::TrackingState::kOk) ++posed;
    }
    const mask::MaskStageStats stats = slam.mask().stats();
    EXPECT_EQ(posed, so.frames) << (late ? "late" : "on time");
    EXPECT_EQ(stats.pose_waits_timed_out, 0u) << (late ? "late" : "on time");
    if (late) {
      EXPECT_EQ(stats.frames_with_fresh_prior, 0u);
      EXPECT_GE(stats.frames_with_ego_motion, static_cast<std::size_t>(so.frames - 3));
      // each made from the pose of the frame before the previous one (MaskPrior::pose_frames_behind 1)
      EXPECT_EQ(stats.frames_with_prior_one_behind, stats.frames_with_ego_motion);
    } else {
      EXPECT_EQ(stats.frames_with_prior_one_behind, 0u);
      EXPECT_GE(stats.frames_with_fresh_prior, static_cast<std::size_t>(so.frames - 2));
    }
  }
}

// The option stands in for live timing in the deterministic loop only: the realtime runner,
// which has that timing itself, refuses it.
TEST(SlamPipeline, RealtimeRunnerRefusesLateMaskPoses) {
  pipeline::PipelineOptions options;
  options.build_map = false;
  options.mask_poses_one_frame_late = true;
  pipeline::SlamPipeline slam(options);
  EXPECT_THROW(pipeline::RealtimeRunner(slam, pipeline::RealtimeOptions()), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
