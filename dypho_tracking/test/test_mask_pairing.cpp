/// MaskPairer: every frame goes on with its own mask, a carried one or none, within the stated
/// wait; nothing piles up, and a backlog thins out evenly; the counters add up.

#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tracking/mask_pairing.h"

namespace DYPHO_UNITY_ID {

using dypho::Timestamp;
using dypho::tracking::MaskPairer;
using dypho::tracking::MaskPairingOptions;
using dypho::tracking::MaskSource;
using Pairer = MaskPairer<int, int>;

constexpr Timestamp kFrameNs = 33'333'333;  // 30 Hz
Timestamp stampOf(int i) { return 1'000'000'000 + i * kFrameNs; }

MaskPairingOptions options(double max_wait_s = 0.1, int max_pending = 4, double carry_s = 0.2) {
  MaskPairingOptions o;
  o.max_wait_s = max_wait_s;
  o.max_pending_frames = max_pending;
  o.max_carry_age_s = carry_s;
  return o;
}

/// Every frame added is released, dropped or still pending; every release is counted once.
void expectCountsAddUp(const Pairer& p) {
  const auto& s = p.stats();
  EXPECT_EQ(s.frames_in, s.matched + s.carried + s.without_mask + s.dropped + p.pending());
}

TEST(MaskPairing, FrameWaitsForItsOwnMask) {
  Pairer p(options());
  p.addFrame(stampOf(0), 100, 0.0);
  EXPECT_TRUE(p.takeReady(0.05).empty()) << "within the wait and no mask: the frame waits";
  ASSERT_TRUE(p.secondsUntilDeadline(0.05).has_value());
  EXPECT_NEAR(*p.secondsUntilDeadline(0.05), 0.05, 1e-9);
  p.addMask(stampOf(0), 7);
  const auto ready = p.takeReady(0.06);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_EQ(ready[0].frame, 100);
  EXPECT_EQ(ready[0].mask, 7);
  EXPECT_EQ(ready[0].source, MaskSource::kMatched);
  EXPECT_NEAR(ready[0].waited_s, 0.06, 1e-9);
  EXPECT_EQ(p.stats().matched, 1u);
  expectCountsAddUp(p);
}

TEST(MaskPairing, AfterTheWaitTheNearestMaskIsCarriedOrNone) {
  Pairer p(options(0.1, 4, 0.1));
  p.addMask(stampOf(0), 10);
  p.addFrame(stampOf(1), 1, 0.0);  // its mask never comes
  EXPECT_TRUE(p.takeReady(0.099).empty());
  auto ready = p.takeReady(0.1);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_EQ(ready[0].source, MaskSource::kCarried);
  EXPECT_EQ(ready[0].mask, 10);
  // Six frames later the old mask is beyond max_carry_age_s (0.1 s = 3 frames): no mask.
  p.addFrame(stampOf(7), 7, 1.0);
  ready = p.takeReady(1.2);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_EQ(ready[0].source, MaskSource::kNone);
  EXPECT_EQ(p.stats().carried, 1u);
  EXPECT_EQ(p.stats().without_mask, 1u);
  expectCountsAddUp(p);
}

TEST(MaskPairing, ALaterMaskReleasesTheSkippedFramesAtOnce) {
  Pairer p(options(10.0));  // a long wait: only the later mask can release frame 0
  p.addFrame(stampOf(0), 0, 0.0);
  p.addFrame(stampOf(1), 1, 0.01);
  p.addMask(stampOf(1), 11);  // the mask stage skipped frame 0
  const auto ready = p.takeReady(0.02);
  ASSERT_EQ(ready.size(), 2u);
  EXPECT_EQ(ready[0].frame, 0);
  EXPECT_EQ(ready[0].source, MaskSource::kCarried);
  EXPECT_EQ(ready[0].mask, 11);
  EXPECT_EQ(ready[1].frame, 1);
  EXPECT_EQ(ready[1].source, MaskSource::kMatched);
  expectCountsAddUp(p);
}

TEST(MaskPairing, FramesLeaveInStampOrder) {
  Pairer p(options());
  p.addFrame(stampOf(0), 0, 0.0);
  p.addFrame(stampOf(1), 1, 0.0);
  p.addMask(stampOf(1), 11);  // would release frame 0 too (a later mask)...
  p.addFrame(stampOf(2), 2, 0.0);
  auto ready = p.takeReady(0.0);
  ASSERT_EQ(ready.size(), 2u);  // ... but frame 2 waits for its own
  EXPECT_EQ(ready[0].frame, 0);
  EXPECT_EQ(ready[1].frame, 1);
  EXPECT_EQ(p.pending(), 1u);
  p.addMask(stampOf(2), 12);
  ready = p.takeReady(0.0);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_EQ(ready[0].frame, 2);
  expectCountsAddUp(p);
}

TEST(MaskPairing, NothingPilesUpBeyondTheBound) {
  Pairer p(options(1.0, 3));
  std::vector<int> dropped;
  for (int i = 0; i < 10; ++i) {
    if (const std::optional<int> d = p.addFrame(stampOf(i), i, 0.0)) dropped.push_back(*d);
  }
  EXPECT_EQ(p.pending(), 3u);
  EXPECT_EQ(p.stats().dropped, 7u);
  // Before any frame went on, the oldest has no frame before it: dropping it leaves no gap.
  EXPECT_EQ(dropped, (std::vector<int>{0, 1, 2, 3, 4, 5, 6})) << "each drop hands back the oldest frame";
  for (int i = 0; i < 10; ++i) p.addMask(stampOf(i), i);
  const auto ready = p.takeReady(0.0);
  ASSERT_EQ(ready.size(), 3u);
  EXPECT_EQ(ready[0].frame, 7) << "the oldest frames are the ones dropped";
  EXPECT_EQ(ready[2].frame, 9);
  expectCountsAddUp(p);
}

// Behind a frame that went on, a backlog thins out: each drop takes the waiting frame whose
// removal leaves the shortest gap, so five drops from ten waiting frames take every other one
// (frames 1, 3, 5, 7, 9) and no gap grows beyond two frame intervals. Dropping the oldest each
// time would have left a gap of six intervals after frame 0 (frames 1-5 gone).
TEST(MaskPairing, ABacklogThinsOutEveryOtherFrame) {
  Pairer p(options(1.0, 10));
  p.addFrame(stampOf(0), 0, 0.0);
  p.addMask(stampOf(0), 0);
  ASSERT_EQ(p.takeReady(0.0).size(), 1u);  // frame 0 went on
  std::vector<int> dropped;
  for (int i = 1; i <= 15; ++i) {
    if (const std::optional<int> d = p.addFrame(stampOf(i), i, 0.0)) dropped.push_back(*d);
  }
  EXPECT_EQ(dropped, (std::vector<int>{1, 3, 5, 7, 9}));
  for (int i = 1; i <= 15; ++i) p.addMask(stampOf(i), i);
  const auto ready = p.takeReady(0.0);
  ASSERT_EQ(ready.size(), 10u);
  int previous = 0;
  for (const auto& r : ready) {
    EXPECT_LE(r.frame - previous, 2) << "a gap of " << r.frame - previous << " frames before frame " << r.frame;
    previous = r.frame;
  }
  EXPECT_EQ(ready.back().frame, 15) << "the newest frame is kept";
  expectCountsAddUp(p);
}

TEST(MaskPairing, LateMasksAreCounted) {
  Pairer p(options(0.05));
  p.addFrame(stampOf(0), 0, 0.0);
  ASSERT_EQ(p.takeReady(0.06).size(), 1u);  // went on without its mask
  p.addMask(stampOf(0), 5);
  EXPECT_EQ(p.stats().late_masks, 1u);
  // The late mask still serves the next frame as a carried one.
  p.addFrame(stampOf(1), 1, 0.1);
  const auto ready = p.takeReady(0.2);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_EQ(ready[0].source, MaskSource::kCarried);
  EXPECT_EQ(ready[0].mask, 5);
}

TEST(MaskPairing, TimeGoingBackForgetsTheMasksAfterIt) {
  Pairer p(options(0.05));
  p.addFrame(stampOf(100), 100, 0.0);
  p.addMask(stampOf(100), 100);
  ASSERT_EQ(p.takeReady(0.0).size(), 1u);
  p.addFrame(stampOf(0), 0, 1.0);  // the bag looped
  auto ready = p.takeReady(1.0);
  EXPECT_TRUE(ready.empty()) << "the frame of the new run waits for its own mask, not a later one";
  ready = p.takeReady(1.1);
  ASSERT_EQ(ready.size(), 1u);
  EXPECT_EQ(ready[0].source, MaskSource::kNone) << "the old run's mask is not carried back in time";
  expectCountsAddUp(p);
}

TEST(MaskPairing, WithoutMasksEveryFrameGoesOnAtOnce) {
  Pairer p(options(), /*expect_masks=*/false);
  p.addFrame(stampOf(0), 0, 0.0);
  p.addFrame(stampOf(1), 1, 0.0);
  const auto ready = p.takeReady(0.0);
  ASSERT_EQ(ready.size(), 2u);
  EXPECT_EQ(ready[0].source, MaskSource::kNone);
  EXPECT_EQ(p.stats().without_mask, 2u);
}

TEST(MaskPairing, BadOptionsAreRejected) {
  EXPECT_THROW(Pairer(options(-1.0)), std::invalid_argument);
  EXPECT_THROW(Pairer(options(0.1, 0)), std::invalid_argument);
  EXPECT_THROW(Pairer(options(0.1, 4, -0.5)), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
