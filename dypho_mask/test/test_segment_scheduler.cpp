// The asynchronous network's scheduling: NetworkBackoff on its own, and SegmentScheduler with a
// generated detector whose results always come back too old (yolo_max_age_frames 0: a result is
// collected one frame after its input at the earliest) or always in time (the limit at 1000).
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>
#include <sys/stat.h>

#include <opencv2/core.hpp>

#include "dypho/mask/dynamic_mask_options.h"
#include "dypho/mask/mask_stage.h"
#include "dypho/mask/segment_scheduler.h"

using namespace dypho;
using namespace dypho::mask;

namespace DYPHO_UNITY_ID {

TEST(NetworkBackoff, LateResultsDoubleTheWaitUpToTheCapAndResultsInTimeHalveIt) {
  NetworkBackoff backoff(8);
  EXPECT_TRUE(backoff.mayStart());
  std::vector<int> waits;
  for (int i = 0; i < 6; ++i) {
    backoff.resultArrived(/*in_time=*/false);
    waits.push_back(backoff.waitFrames());
  }
  EXPECT_EQ(waits, (std::vector<int>{1, 2, 4, 8, 8, 8}));
  // The wait counts frames seen since the result.
  for (int f = 0; f < 8; ++f) {
    EXPECT_FALSE(backoff.mayStart()) << "after " << f << " frames";
    backoff.frameSeen();
  }
  EXPECT_TRUE(backoff.mayStart());
  std::vector<int> halved;
  for (int i = 0; i < 5; ++i) {
    backoff.resultArrived(/*in_time=*/true);
    halved.push_back(backoff.waitFrames());
  }
  EXPECT_EQ(halved, (std::vector<int>{4, 2, 1, 0, 0}));
  EXPECT_TRUE(backoff.mayStart());
}

TEST(NetworkBackoff, ACapOfZeroNeverWaits) {
  NetworkBackoff backoff(0);
  for (int i = 0; i < 3; ++i) {
    backoff.resultArrived(/*in_time=*/false);
    EXPECT_EQ(backoff.waitFrames(), 0);
    EXPECT_TRUE(backoff.mayStart());
  }
}

TEST(NetworkBackoff, ResetForgetsTheWait) {
  NetworkBackoff backoff(32);
  backoff.resultArrived(false);
  backoff.resultArrived(false);
  ASSERT_EQ(backoff.waitFrames(), 2);
  backoff.reset();
  EXPECT_EQ(backoff.waitFrames(), 0);
  EXPECT_TRUE(backoff.mayStart());
}

const std::string kModels = DYPHO_TEST_MODELS_DIR;

bool modelsExist() {
  struct stat st;
  return ::stat((kModels + "/yolov8_det.onnx").c_str(), &st) == 0;
}

struct Step {
  bool started = false;
  bool late = false;
  int wait = 0;
};

/// Runs `frames` frames through an asynchronous scheduler, waiting after each frame until the
/// network's run has finished, so that every result is collected on the frame after the one it was
/// started on (a camera slower than the network would do the same).
std::vector<Step> runAsync(int max_age_frames, int backoff_max_frames, int frames) {
  YoloOptions y;
  y.model_path = kModels + "/yolov8_det.onnx";
  y.input_size_px = 64;
  y.dynamic_classes = "0,2";
  y.async = true;
  y.max_age_frames = max_age_frames;
  y.async_backoff_max_frames = backoff_max_frames;
  SegmentScheduler scheduler(y);
  EXPECT_TRUE(scheduler.ready()) << scheduler.status();
  RgbdFrame frame;
  frame.bgr = cv::Mat(64, 64, CV_8UC3, cv::Scalar(0, 0, 0));
  frame.depth_m = cv::Mat(64, 64, CV_32FC1, cv::Scalar(2.0f));
  std::vector<Step> steps;
  for (int i = 0; i < frames; ++i) {
    const SegmentStep s = scheduler.step(frame, cv::Mat());
    steps.push_back({s.network_started, s.late_result, s.network_wait_frames});
    const auto t0 = std::chrono::steady_clock::now();
    while (scheduler.networkBusy() && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_FALSE(scheduler.networkBusy()) << "the generated model ran for 10 s";
  }
  return steps;
}

// Every result one frame old against a limit of 0: the network's starts spread out as the wait
// doubles up to the cap (4 here): started on frame 0, late results on frames 1, 3, 6, 11, 16
// with waits 1, 2, 4, 4, 4, and started again once each wait has passed.
TEST(SegmentScheduler, AsyncNetworkWaitsLongerAfterEachLateResult) {
  if (!modelsExist()) GTEST_SKIP() << "generated ONNX models missing in " << kModels << " (python3-onnx)";
  const std::vector<Step> steps = runAsync(/*max_age_frames=*/0, /*backoff_max_frames=*/4, 20);
  std::vector<int> started, late, waits;
  for (int i = 0; i < static_cast<int>(steps.size()); ++i) {
    if (steps[i].started) started.push_back(i);
    if (steps[i].late) {
      late.push_back(i);
      waits.push_back(steps[i].wait);
    }
  }
  EXPECT_EQ(started, (std::vector<int>{0, 2, 5, 10, 15}));
  EXPECT_EQ(late, (std::vector<int>{1, 3, 6, 11, 16}));
  EXPECT_EQ(waits, (std::vector<int>{1, 2, 4, 4, 4}));
}

// Without the backoff (cap 0) the same late network starts again on the frame its result comes
// back on, every frame; with results in time (limit 1000) the backoff never waits either.
TEST(SegmentScheduler, AsyncNetworkRunsBackToBackWithoutBackoffOrWhenInTime) {
  if (!modelsExist()) GTEST_SKIP() << "generated ONNX models missing in " << kModels << " (python3-onnx)";
  for (const auto& [max_age, cap] : {std::pair{0, 0}, std::pair{1000, 32}}) {
    const std::vector<Step> steps = runAsync(max_age, cap, 9);
    std::vector<int> started;
    for (int i = 0; i < static_cast<int>(steps.size()); ++i) {
      if (steps[i].started) started.push_back(i);
      EXPECT_EQ(steps[i].wait, 0) << "frame " << i;
      EXPECT_EQ(steps[i].late, max_age == 0 && i >= 1) << "frame " << i;
    }
    EXPECT_EQ(started, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8})) << "limit " << max_age << ", cap " << cap;
  }
}

// The stage's counters (the runner's summary and the mask status message report them): a network
// run on every frame, its mask judging each; none late without the asynchronous worker.
TEST(SegmentScheduler, MaskStageCountsTheNetworksRunsAndTheFramesItJudged) {
  if (!modelsExist()) GTEST_SKIP() << "generated ONNX models missing in " << kModels << " (python3-onnx)";
  DynamicMaskOptions options;
  options.yolo.model_path = kModels + "/yolov8_det.onnx";
  options.yolo.input_size_px = 64;
  options.yolo.dynamic_classes = "0,2";
  MaskStage stage(options);
  RgbdFrame frame;
  frame.bgr = cv::Mat(64, 64, CV_8UC3, cv::Scalar(0, 0, 0));
  frame.depth_m = cv::Mat(64, 64, CV_32FC1, cv::Scalar(2.0f));
  frame.camera.width = 64;
  frame.camera.height = 64;
  frame.camera.fx = frame.camera.fy = 60.0;
  frame.camera.cx = frame.camera.cy = 32.0;
  for (int i = 0; i < 3; ++i) {
    frame.stamp_ns = 1000000000LL + i * 33000000LL;
    const MaskResult r = stage.process(frame);
    EXPECT_TRUE(r.network_started) << "frame " << i << ": " << r.message;
    EXPECT_FALSE(r.network_result_late) << "frame " << i;
  }
  const MaskStageStats stats = stage.stats();
  EXPECT_EQ(stats.network_runs, 3u);
  EXPECT_EQ(stats.network_results_late, 0u);
  EXPECT_EQ(stats.frames_with_network_mask, 3u);
}

}  // namespace DYPHO_UNITY_ID
