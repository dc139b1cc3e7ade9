/// BoundedHandOver: arrival order, the oldest dropped when full, drained after close, and the
/// waiting push that never drops.
#include <atomic>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/common/bounded_hand_over.h"

namespace dypho {
namespace DYPHO_UNITY_ID {

TEST(BoundedHandOver, KeepsOrderDropsTheOldestWhenFullAndDrainsAfterClose) {
  dypho::BoundedHandOver<int> q(2);
  EXPECT_FALSE(q.push(1).has_value());
  EXPECT_FALSE(q.push(2).has_value());
  const std::optional<int> dropped = q.push(3);  // full: 1 makes room
  ASSERT_TRUE(dropped.has_value());
  EXPECT_EQ(*dropped, 1);
  EXPECT_EQ(q.pop(), std::optional<int>(2));
  q.close();
  EXPECT_EQ(q.pop(), std::optional<int>(3));  // what waited is still handed out
  EXPECT_EQ(q.pop(), std::nullopt);
  EXPECT_EQ(q.push(4), std::optional<int>(4));  // after close nothing is taken
  EXPECT_THROW(dypho::BoundedHandOver<int>(0), std::invalid_argument);
}

/// pushWhenRoom waits for the consumer instead of dropping; close() releases a waiting producer.
TEST(BoundedHandOver, PushWhenRoomWaitsForTheConsumerAndNeverDrops) {
  dypho::BoundedHandOver<int> q(1);
  std::atomic<int> pushed{0};
  std::thread producer([&] {
    for (int i = 0; i < 50; ++i) {
      if (q.pushWhenRoom(int(i))) ++pushed;
    }
  });
  std::vector<int> taken;
  while (taken.size() < 50u) taken.push_back(*q.pop());
  producer.join();
  EXPECT_EQ(pushed.load(), 50);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(taken[static_cast<std::size_t>(i)], i);  // all, in order

  dypho::BoundedHandOver<int> full(1);
  ASSERT_TRUE(full.pushWhenRoom(1));
  std::atomic<bool> second_returned{false}, second_result{true};
  std::thread blocked([&] {
    second_result = full.pushWhenRoom(2);  // waits: the queue is full
    second_returned = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(second_returned.load());  // still waiting for room
  full.close();
  blocked.join();
  EXPECT_FALSE(second_result.load());  // released by close(), item not taken
  EXPECT_EQ(full.pop(), std::optional<int>(1));
  EXPECT_EQ(full.pop(), std::nullopt);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho
