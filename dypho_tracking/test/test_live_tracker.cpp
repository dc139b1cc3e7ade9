/// LiveTracker, the live code of the tracking nodelet and of dypho_run_dataset --realtime: frames
/// paired with their masks (or carried ones after the wait), tracked in stamp order, drops handed
/// back and counted, every frame accounted for after stop() or finish(), failures reported and
/// survived. No assertion waits on the clock except lower bounds (a wait is never shorter).
#include <atomic>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tracking/live_tracker.h"
#include "synthetic_scene.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

constexpr Timestamp kDt = 33'333'333;  // 30 Hz
constexpr int kFrames = 12;

Timestamp stampOf(int i) { return (i + 1) * kDt; }

/// A textured wall the camera slides along: every frame tracks.
const std::vector<RgbdFrame>& frames() {
  static const std::vector<RgbdFrame> f = [] {
    const cv::Mat img = test::texturedImage(31);
    std::vector<RgbdFrame> out;
    for (int i = 0; i < kFrames; ++i) out.push_back(test::planarFrame(test::shifted(img, 3 * i, 0), 2.0, stampOf(i)));
    return out;
  }();
  return f;
}

/// Input: the frame's index. Mask: the index of the frame it was made for, + 1 (0 = none).
using Live = LiveTracker<int, int>;

/// What the sink and the failure sink saw.
struct Seen {
  std::mutex mutex;
  std::vector<int> frames;  ///< indices, in sink order
  std::vector<MaskSource> sources;
  std::vector<int> masks;
  std::vector<double> mask_wait_ms;
  std::vector<std::string> failures;
  std::vector<Timestamp> failed_stamps;
};

Live::Callbacks callbacks(Seen& seen, std::function<void(int)> on_convert = {}, std::function<void(int)> on_sink = {}) {
  Live::Callbacks c;
  c.convert = [on_convert](const Live::Ready& r) {
    if (on_convert) on_convert(r.frame);
    LiveFrame out;
    out.frame = frames().at(static_cast<std::size_t>(r.frame));
    if (r.mask != 0) out.mask = cv::Mat::zeros(out.frame.bgr.size(), CV_8UC1);
    return out;
  };
  c.sink = [&seen, on_sink](Live::Tracked& t) {
    if (on_sink) on_sink(t.ready.frame);
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.frames.push_back(t.ready.frame);
    seen.sources.push_back(t.ready.source);
    seen.masks.push_back(t.ready.mask);
    seen.mask_wait_ms.push_back(t.live.mask_wait_ms);
    EXPECT_FALSE(t.output.dropped) << t.output.result.message;
    EXPECT_EQ(t.output.result.stamp_ns, t.ready.stamp_ns);
  };
  c.failure = [&seen](const LiveFailure& f) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.failures.push_back(f.message);
    seen.failed_stamps.push_back(f.stamp_ns);
    EXPECT_TRUE(f.error != nullptr);
  };
  return c;
}

MaskPairingOptions pairing(double max_wait_s, int max_pending = 30, double carry_s = 0.2) {
  MaskPairingOptions o;
  o.max_wait_s = max_wait_s;
  o.max_pending_frames = max_pending;
  o.max_carry_age_s = carry_s;
  return o;
}

/// Every frame added is processed, dropped or discarded; every processed one reached a sink.
void expectConserved(const LiveCounters& c, const Seen& seen) {
  EXPECT_EQ(c.frames_in, c.frames_processed + c.frames_dropped + c.frames_discarded);
  EXPECT_EQ(c.frames_processed, seen.frames.size() + seen.failures.size());
  EXPECT_EQ(c.frames_failed, seen.failures.size());
  for (std::size_t k = 1; k < seen.frames.size(); ++k) {
    EXPECT_LT(seen.frames[k - 1], seen.frames[k]) << "the sink sees frames in stamp order";
  }
}

TEST(LiveJudgement, FollowsTheMaskSource) {
  EXPECT_EQ(liveJudgement(MaskSource::kMatched, true, MaskJudgement::kJudged), MaskJudgement::kJudged);
  EXPECT_EQ(liveJudgement(MaskSource::kMatched, true, MaskJudgement::kUnjudged), MaskJudgement::kUnjudged)
      << "the frame's own mask did not judge it (a flow mask's first frame)";
  EXPECT_EQ(liveJudgement(MaskSource::kCarried, true, MaskJudgement::kJudged), MaskJudgement::kUnjudged);
  EXPECT_EQ(liveJudgement(MaskSource::kNone, true, MaskJudgement::kJudged), MaskJudgement::kUnjudged);
  EXPECT_EQ(liveJudgement(MaskSource::kNone, false, MaskJudgement::kJudged), MaskJudgement::kUnknown)
      << "no masks expected at all";
}

// Masks released only by their own arrival (a wait of 100 s): every frame is tracked with its own
// mask, in stamp order, and the stage recorded exactly those stamps.
TEST(LiveTracker, FramesWithTheirMasksAreTrackedInStampOrder) {
  TrackingStage stage{TrackingOptions()};
  Seen seen;
  {
    Live live(stage, pairing(100.0), true, callbacks(seen));
    for (int i = 0; i < kFrames; ++i) {
      EXPECT_FALSE(live.addFrame(stampOf(i), i).has_value());
      live.addMask(stampOf(i), i + 1);
    }
    live.finish();
    const LiveCounters c = live.counters();
    expectConserved(c, seen);
    EXPECT_EQ(c.frames_in, static_cast<std::uint64_t>(kFrames));
    EXPECT_EQ(c.frames_matched, static_cast<std::uint64_t>(kFrames));
    EXPECT_EQ(c.frames_dropped + c.frames_discarded + c.frames_failed, 0u);
  }
  ASSERT_EQ(seen.frames.size(), static_cast<std::size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    EXPECT_EQ(seen.frames[i], i);
    EXPECT_EQ(seen.sources[i], MaskSource::kMatched);
    EXPECT_EQ(seen.masks[i], i + 1);
  }
  const PoseList online = stage.onlineTrajectory();
  ASSERT_EQ(online.size(), static_cast<std::size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) EXPECT_EQ(online[i].first, stampOf(i));
}

// A frame whose mask never comes goes on after max_wait_s with the nearest mask in time (within
// max_carry_age_s), or with none when no mask is near enough; the wait is at least max_wait_s.
TEST(LiveTracker, AFrameWithoutItsMaskGoesOnAfterTheWait) {
  TrackingStage stage{TrackingOptions()};
  Seen seen;
  const double wait_s = 0.05;
  Live live(stage, pairing(wait_s, 30, 0.2), true, callbacks(seen));
  live.addMask(stampOf(0), 1);
  live.addFrame(stampOf(0), 0);
  live.addFrame(stampOf(1), 1);    // 33 ms from frame 0's mask: carried
  live.addFrame(stampOf(10), 10);  // 333 ms from it: none
  live.finish();
  ASSERT_EQ(seen.frames, (std::vector<int>{0, 1, 10}));
  EXPECT_EQ(seen.sources[0], MaskSource::kMatched);
  EXPECT_EQ(seen.sources[1], MaskSource::kCarried);
  EXPECT_EQ(seen.masks[1], 1) << "frame 0's mask";
  EXPECT_EQ(seen.sources[2], MaskSource::kNone);
  EXPECT_GE(seen.mask_wait_ms[1], wait_s * 1e3 - 1e-6);
  EXPECT_GE(seen.mask_wait_ms[2], wait_s * 1e3 - 1e-6);
  const LiveCounters c = live.counters();
  expectConserved(c, seen);
  EXPECT_EQ(c.frames_matched, 1u);
  EXPECT_EQ(c.frames_mask_carried, 1u);
  EXPECT_EQ(c.frames_without_mask, 1u);
}

// Beyond max_pending_frames a waiting frame is dropped (before any frame went on: the oldest),
// handed back to the caller and counted; stop() discards the frames still waiting and refuses later ones, all counted.
TEST(LiveTracker, BeyondTheBoundTheOldestFrameIsDroppedAndHandedBack) {
  TrackingStage stage{TrackingOptions()};
  Seen seen;
  Live live(stage, pairing(100.0, 2), true, callbacks(seen));
  std::vector<int> dropped;
  for (int i = 0; i < 6; ++i) {
    if (const std::optional<int> d = live.addFrame(stampOf(i), i)) dropped.push_back(*d);
  }
  EXPECT_EQ(dropped, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(live.framesWaiting(), 2u);
  live.stop();
  EXPECT_FALSE(live.addFrame(stampOf(7), 7).has_value());  // after stop: refused
  const LiveCounters c = live.counters();
  expectConserved(c, seen);
  EXPECT_EQ(c.frames_in, 7u);
  EXPECT_EQ(c.frames_dropped, 4u);
  EXPECT_EQ(c.frames_discarded, 3u);
  EXPECT_EQ(c.frames_processed, 0u);
  EXPECT_TRUE(seen.frames.empty());
  EXPECT_EQ(stage.numFrames(), 0u);
}

// stop() with frames in flight (no masks expected: every frame goes on at once) ends promptly:
// no frame is lost uncounted, and the ones tracked are in stamp order.
TEST(LiveTracker, StopWithFramesInFlightAccountsForEveryFrame) {
  TrackingStage stage{TrackingOptions()};
  Seen seen;
  Live live(stage, pairing(0.1), false, callbacks(seen));
  for (int i = 0; i < kFrames; ++i) live.addFrame(stampOf(i), i);
  live.stop();
  live.stop();  // idempotent
  const LiveCounters c = live.counters();
  expectConserved(c, seen);
  EXPECT_EQ(c.frames_in, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(c.frames_without_mask, 0u) << "not counted when no masks are expected";
  for (MaskSource s : seen.sources) EXPECT_EQ(s, MaskSource::kNone);
  EXPECT_EQ(stage.numFrames(), seen.frames.size());
}

// A frame that cannot be converted, or whose mask has the wrong size, is reported and dropped;
// the next frames go on. A sink that throws is reported too.
TEST(LiveTracker, FailuresAreReportedAndTheNextFramesGoOn) {
  TrackingStage stage{TrackingOptions()};
  Seen seen;
  auto c = callbacks(
      seen,
      [](int i) {
        if (i == 2) throw std::runtime_error("unreadable on purpose");
      },
      [](int i) {
        if (i == 5) throw std::runtime_error("publishing failed on purpose");
      });
  auto convert = c.convert;
  c.convert = [convert](const Live::Ready& r) {
    LiveFrame f = convert(r);
    if (r.frame == 3) f.mask = cv::Mat::zeros(10, 10, CV_8UC1);
    return f;
  };
  Live live(stage, pairing(100.0), true, std::move(c));
  for (int i = 0; i < 7; ++i) {
    live.addFrame(stampOf(i), i);
    live.addMask(stampOf(i), i + 1);
  }
  live.finish();
  const LiveCounters counters = live.counters();
  expectConserved(counters, seen);
  EXPECT_EQ(counters.frames_failed, 3u);
  ASSERT_EQ(seen.failures.size(), 3u);
  EXPECT_NE(seen.failures[0].find("unreadable on purpose"), std::string::npos) << seen.failures[0];
  EXPECT_EQ(seen.failed_stamps[0], stampOf(2));
  EXPECT_NE(seen.failures[1].find("mask is 10x10"), std::string::npos) << seen.failures[1];
  EXPECT_NE(seen.failures[2].find("publishing failed on purpose"), std::string::npos) << seen.failures[2];
  EXPECT_EQ(seen.frames, (std::vector<int>{0, 1, 4, 6}));
  EXPECT_EQ(stage.numFrames(), 5u) << "frame 5 was tracked; its sink failed";
}

TEST(LiveTracker, RejectsMissingCallbacksAndBadOptions) {
  TrackingStage stage{TrackingOptions()};
  EXPECT_THROW(Live(stage, pairing(0.1), true, Live::Callbacks{}), std::invalid_argument);
  Seen seen;
  EXPECT_THROW(Live(stage, pairing(-1.0), true, callbacks(seen)), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
