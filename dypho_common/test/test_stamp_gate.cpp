/// StampGate: repeated and late stamps dropped, a jump back restarts, extreme stamps safe.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "dypho/common/stamp_gate.h"

namespace DYPHO_UNITY_ID {

using namespace dypho;

constexpr Timestamp kFrameNs = 33'333'333;  // 30 Hz

TEST(StampGate, DropsRepeatedAndLateFramesRestartsOnAJumpBack) {
  StampGate gate(1.0);
  EXPECT_EQ(gate.admit(10 * kFrameNs), StampOrder::kNext);
  EXPECT_EQ(gate.admit(11 * kFrameNs), StampOrder::kNext);
  EXPECT_EQ(gate.admit(11 * kFrameNs), StampOrder::kRepeated);
  EXPECT_EQ(gate.admit(9 * kFrameNs), StampOrder::kLate);                   // 2 frames late
  EXPECT_EQ(gate.admit(12 * kFrameNs), StampOrder::kNext);                  // the newest stays 11, then 12
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

}  // namespace DYPHO_UNITY_ID
