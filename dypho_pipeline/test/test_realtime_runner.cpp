/// The realtime runner (dypho_run_dataset --realtime) on a short synthetic sequence, through the
/// tracking nodelet's live code (LiveTracker, tested on its own in dypho_tracking): every released
/// frame is either processed or dropped and counted, dropped frames have no pose, a frame the mask
/// skipped is tracked with a carried mask, and the default deterministic path is unchanged. Invariants only: which
/// frames are dropped depends on the machine's load, so no assertion depends on timing except where the margin is three
/// orders of magnitude (stated at the test).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/pipeline/realtime_runner.h"
#include "dypho/pipeline/slam_pipeline.h"
#include "dypho/tools/synthetic_scene.h"

namespace dypho {
namespace DYPHO_UNITY_ID {

TEST(RealtimeOptions, RejectsBadValues) {
  pipeline::RealtimeOptions o;
  EXPECT_NO_THROW(o.validate());
  o.speed = 0.0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.speed = std::nan("");
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.speed = 1.0;
  o.queue_capacity_frames = 0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.queue_capacity_frames = 2;
  o.prefetch_frames = 0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

TEST(RealtimeRunner, PercentileIsTheNearestRank) {
  EXPECT_EQ(pipeline::percentile({}, 0.5), 0.0);
  EXPECT_EQ(pipeline::percentile({3.0, 1.0, 2.0, 4.0}, 0.5), 2.0);
  EXPECT_EQ(pipeline::percentile({3.0, 1.0, 2.0, 4.0}, 0.95), 4.0);
  EXPECT_EQ(pipeline::percentile({3.0, 1.0, 2.0, 4.0}, 0.0), 1.0);
}

TEST(RealtimeRunner, LivePolicyTurnsTheNetworkAsynchronousOnlyWithAModel) {
  pipeline::PipelineOptions o;
  EXPECT_TRUE(pipeline::applyLivePolicy(o).empty()) << "no model: nothing to change";
  EXPECT_FALSE(o.mask.yolo.async);
  o.mask.yolo.model_path = "model.onnx";
  EXPECT_EQ(pipeline::applyLivePolicy(o).size(), 1u);
  EXPECT_TRUE(o.mask.yolo.async);
  EXPECT_TRUE(pipeline::applyLivePolicy(o).empty()) << "already asynchronous";
}

constexpr int kFrames = 30;

/// A short synthetic sequence, rendered once for all tests (rendering is not what is measured).
const std::vector<tools::SynthFrame>& frames() {
  static const std::vector<tools::SynthFrame> rendered = [] {
    tools::SynthOptions so;
    so.frames = kFrames;
    so.people = 1;
    so.seed = 7;
    const tools::SyntheticScene scene(so);
    std::vector<tools::SynthFrame> f;
    for (int i = 0; i < kFrames; ++i) f.push_back(scene.render(i));
    return f;
  }();
  return rendered;
}

pipeline::PipelineOptions shortOptions() {
  pipeline::PipelineOptions options;
  options.mapping.gaussian.iterations_per_keyframe = 2;  // keeps the test short
  options.mapping.gaussian.final_refine_iterations = 0;
  return options;
}

pipeline::RealtimeFrameLoader loader(std::set<std::size_t> unreadable = {}) {
  return [unreadable](std::size_t i) {
    if (unreadable.count(i) != 0) throw std::runtime_error("unreadable on purpose");
    return pipeline::RealtimeInput{frames().at(i).frame, cv::Mat()};
  };
}

/// The invariants of any realtime run of `released` frames through `slam`.
void checkAccounting(const pipeline::RealtimeResult& r, std::size_t released, pipeline::SlamPipeline& slam) {
  EXPECT_EQ(r.frames_in, released);
  EXPECT_EQ(r.frames_in, r.processed.size() + r.framesDropped()) << "every released frame is processed or dropped";
  std::set<std::size_t> seen;
  for (const auto& f : r.processed) EXPECT_TRUE(seen.insert(f.index).second) << "frame " << f.index << " twice";
  for (std::size_t i : r.dropped_before_tracking) EXPECT_TRUE(seen.insert(i).second) << "frame " << i << " twice";
  EXPECT_EQ(seen.size(), released);
  // The live tracker's own counters say the same.
  EXPECT_EQ(r.live.frames_in, released);
  EXPECT_EQ(r.live.frames_processed, r.processed.size());
  EXPECT_EQ(r.live.frames_dropped, r.framesDropped());
  EXPECT_EQ(r.live.frames_discarded + r.live.frames_failed, 0u);
  // Tracking finishes frames in sequence order (the pairer releases in stamp order).
  for (std::size_t k = 1; k < r.processed.size(); ++k) EXPECT_LT(r.processed[k - 1].index, r.processed[k].index);
  const std::set<std::size_t> skipped(r.masks_skipped.begin(), r.masks_skipped.end());
  EXPECT_EQ(skipped.size(), r.masks_skipped.size()) << "a mask skipped twice";
  for (const auto& f : r.processed) {
    EXPECT_TRUE(std::isfinite(f.latency_ms) && f.latency_ms >= 0.0) << "frame " << f.index << ": " << f.latency_ms;
    EXPECT_FALSE(f.report.dropped) << "distinct increasing stamps: the stamp gate rejects none";
    if (skipped.count(f.index) != 0) {
      EXPECT_NE(f.mask_source, tracking::MaskSource::kMatched) << "frame " << f.index << " was never masked";
    }
    if (f.mask_source != tracking::MaskSource::kMatched) {
      EXPECT_EQ(f.report.mask_ms, 0.0) << "frame " << f.index << ": another frame's mask";
    }
  }
  EXPECT_EQ(r.framesWithMask(tracking::MaskSource::kMatched) + r.framesWithMask(tracking::MaskSource::kCarried) +
                r.framesWithMask(tracking::MaskSource::kNone),
            r.processed.size());
  // Exactly the processed frames have a pose, with their stamps; dropped frames have none.
  const tracking::PoseList trajectory = slam.tracking().onlineTrajectory();
  ASSERT_EQ(trajectory.size(), r.framesPosed());
  for (std::size_t k = 0; k < trajectory.size(); ++k) {
    EXPECT_EQ(trajectory[k].first, frames().at(r.processed[k].index).frame.stamp_ns) << "pose " << k;
  }
  // A latency runs from a frame's release to its pose, both inside the run's wall time.
  EXPECT_LE(r.latencyPercentileMs(1.0), r.wall_s * 1e3);
}

// At the camera's rate (speed 1.0) with the live policy: frames are processed, the count adds
// up, one unreadable frame is skipped and named, never released.
TEST(RealtimeRunner, AtCameraRateEveryFrameIsProcessedOrDropped) {
  pipeline::SlamPipeline slam(shortOptions(), mapping::MappingMode::kLive);
  pipeline::RealtimeRunner runner(slam, pipeline::RealtimeOptions());
  const pipeline::RealtimeResult r = runner.run(kFrames, loader({5}));
  slam.finish();
  ASSERT_EQ(r.unreadable.size(), 1u);
  EXPECT_NE(r.unreadable[0].find("frame 5"), std::string::npos) << r.unreadable[0];
  checkAccounting(r, kFrames - 1, slam);
  EXPECT_GT(r.framesPosed(), 0u);
  EXPECT_FALSE(r.stopped);
  // At speed 1.0 the last frame is released no earlier than its stamp's offset from the first.
  const double span_s = timestampToSeconds(frames().at(kFrames - 1).frame.stamp_ns - frames().at(0).frame.stamp_ns);
  EXPECT_GE(r.wall_s, span_s);
}

// All frames released at once (speed 1e6: 30 frames within 1 us of stamp time) into a mask queue
// of one frame: the mask cannot take them in time (a mask costs milliseconds, three orders of
// magnitude more), so it skips frames, and tracking carries masks to them. Within the tracking
// bound (30 frames waiting) no frame is dropped.
TEST(RealtimeRunner, AMaskSlowerThanTheCameraIsCarriedNotDropped) {
  pipeline::SlamPipeline slam(shortOptions(), mapping::MappingMode::kLive);
  pipeline::RealtimeOptions ro;
  ro.speed = 1e6;
  ro.queue_capacity_frames = 1;
  const pipeline::RealtimeResult r = pipeline::RealtimeRunner(slam, ro).run(kFrames, loader());
  slam.finish();
  checkAccounting(r, kFrames, slam);
  EXPECT_GT(r.masks_skipped.size(), 0u);
  EXPECT_EQ(r.framesDropped(), 0u) << "30 frames fit in mask_max_pending_frames (30)";
  EXPECT_GT(r.framesWithMask(tracking::MaskSource::kCarried) + r.framesWithMask(tracking::MaskSource::kNone), 0u);
}

// The same with a tracking bound of 2 frames: frames are dropped, deliberately and counted, and
// nothing piles up.
TEST(RealtimeRunner, FasterThanThePipelineDropsAndCountsFrames) {
  pipeline::PipelineOptions options = shortOptions();
  options.mask_pairing.max_pending_frames = 2;
  pipeline::SlamPipeline slam(options, mapping::MappingMode::kLive);
  pipeline::RealtimeOptions ro;
  ro.speed = 1e6;
  ro.queue_capacity_frames = 1;
  const pipeline::RealtimeResult r = pipeline::RealtimeRunner(slam, ro).run(kFrames, loader());
  slam.finish();
  checkAccounting(r, kFrames, slam);
  EXPECT_GT(r.framesDropped(), 0u);
  EXPECT_GT(r.processed.size(), 0u) << "the newest frames are always taken";
}

// Without masks (mask source none, the graph with use_mask false) nothing is masked: every
// frame goes to tracking at once, without a mask.
TEST(RealtimeRunner, WithoutMasksEveryFrameIsTrackedWithoutOne) {
  pipeline::PipelineOptions options = shortOptions();
  options.mask_source = pipeline::MaskSource::kNone;
  pipeline::SlamPipeline slam(options, mapping::MappingMode::kLive);
  pipeline::RealtimeOptions ro;
  ro.speed = 4.0;
  const pipeline::RealtimeResult r = pipeline::RealtimeRunner(slam, ro).run(kFrames, loader());
  slam.finish();
  checkAccounting(r, kFrames, slam);
  EXPECT_TRUE(r.masks_skipped.empty());
  EXPECT_EQ(r.framesWithMask(tracking::MaskSource::kNone), r.processed.size());
  EXPECT_EQ(r.live.frames_without_mask, 0u) << "none expected: not counted as missing";
}

// A stop flag set before the run releases nothing.
TEST(RealtimeRunner, StopFlagReleasesNothingMore) {
  pipeline::SlamPipeline slam(shortOptions(), mapping::MappingMode::kLive);
  pipeline::RealtimeRunner runner(slam, pipeline::RealtimeOptions());
  const std::atomic<bool> stop{true};
  const pipeline::RealtimeResult r = runner.run(kFrames, loader(), &stop);
  EXPECT_TRUE(r.stopped);
  EXPECT_EQ(r.frames_in, 0u);
  EXPECT_TRUE(r.processed.empty());
  EXPECT_EQ(slam.tracking().numFrames(), 0u);
}

// A stop flag set while frames are in flight (by the loader, as frame 10 is read): no later
// frame is released, and every released one is still accounted for.
TEST(RealtimeRunner, StopFlagMidRunFinishesTheReleasedFrames) {
  pipeline::SlamPipeline slam(shortOptions(), mapping::MappingMode::kLive);
  pipeline::RealtimeOptions ro;
  ro.speed = 4.0;
  std::atomic<bool> stop{false};
  const pipeline::RealtimeFrameLoader load = [&stop](std::size_t i) {
    if (i == 10) stop = true;
    return pipeline::RealtimeInput{frames().at(i).frame, cv::Mat()};
  };
  const pipeline::RealtimeResult r = pipeline::RealtimeRunner(slam, ro).run(kFrames, load, &stop);
  slam.finish();
  EXPECT_TRUE(r.stopped);
  EXPECT_LE(r.frames_in, 10u) << "frame 10 and later are never released";
  checkAccounting(r, r.frames_in, slam);
}

// A frame tracking cannot take (an external mask of the wrong size) ends the run: the error
// comes out of run(), after the threads ended.
TEST(RealtimeRunner, AStageThatThrowsEndsTheRunWithItsError) {
  pipeline::PipelineOptions options = shortOptions();
  options.mask_source = pipeline::MaskSource::kExternal;
  pipeline::SlamPipeline slam(options, mapping::MappingMode::kLive);
  const pipeline::RealtimeFrameLoader load = [](std::size_t i) {
    const RgbdFrame& frame = frames().at(i).frame;
    cv::Mat mask = cv::Mat::zeros(i == 3 ? cv::Size(8, 8) : frame.bgr.size(), CV_8UC1);
    return pipeline::RealtimeInput{frame, mask};
  };
  pipeline::RealtimeOptions ro;
  ro.speed = 4.0;
  try {
    pipeline::RealtimeRunner(slam, ro).run(kFrames, load);
    ADD_FAILURE() << "run() returned";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mask is 8x8"), std::string::npos) << e.what();
  }
  slam.finish();
}

std::vector<Eigen::Isometry3d> deterministicPoses(bool split) {
  pipeline::SlamPipeline slam(shortOptions());
  std::vector<Eigen::Isometry3d> poses;
  for (const tools::SynthFrame& f : frames()) {
    const pipeline::FrameReport r = split ? slam.trackFrame(slam.maskFrame(f.frame)) : slam.process(f.frame);
    poses.push_back(r.tracking.T_world_camera);
  }
  return poses;
}

// The default path is untouched: process() is maskFrame() then trackFrame() to the bit, and a
// realtime run in between leaves no state behind that changes a deterministic run.
TEST(RealtimeRunner, DefaultDeterministicRunIsUnaffected) {
  const std::vector<Eigen::Isometry3d> a = deterministicPoses(false);
  {
    pipeline::SlamPipeline slam(shortOptions(), mapping::MappingMode::kLive);
    pipeline::RealtimeRunner(slam, pipeline::RealtimeOptions()).run(kFrames, loader());
    slam.finish();
  }
  const std::vector<Eigen::Isometry3d> b = deterministicPoses(true);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_TRUE(a[i].matrix() == b[i].matrix()) << "frame " << i;
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho
