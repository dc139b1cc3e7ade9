/// MappingWorker's queue policy on its own (no training): the live merge keeps the order.
#include <gtest/gtest.h>

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "dypho/mapping/mapping_worker.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

// The worker's merge keeps the order of keyframes and corrections.
TEST(MappingWorker, AFullLiveQueueMergesInOrder) {
  std::mutex m;
  std::condition_variable cv;
  bool release = false;
  std::vector<std::vector<std::int64_t>> seen;  // keyframe ids per job, as the handler got them
  std::vector<std::size_t> corrections_seen;
  MappingWorker worker(1, [&](const MappingJob& job) {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return release; });
    std::vector<std::int64_t> ids;
    for (const auto& kf : job.keyframes) ids.push_back(kf->id);
    seen.push_back(ids);
    corrections_seen.push_back(job.corrections.size());
  });
  const auto job = [](std::int64_t id) {
    auto kf = std::make_shared<Keyframe>();
    kf->id = id;
    return MappingJob{{kf}, {}};
  };
  EXPECT_TRUE(worker.push(job(0), false));
  while (worker.queued() > 0) std::this_thread::yield();  // job 0 runs (and waits for the release)
  EXPECT_TRUE(worker.push(job(1), false));
  EXPECT_FALSE(worker.push(job(2), false));
  EXPECT_FALSE(worker.push(MappingJob{{}, {{1, Eigen::Isometry3d::Identity()}}}, false));
  EXPECT_FALSE(worker.push(job(3), false));
  EXPECT_EQ(worker.merged(), 3u);
  {
    std::lock_guard<std::mutex> lock(m);
    release = true;
  }
  cv.notify_all();
  worker.waitUntilIdle();
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0], std::vector<std::int64_t>({0}));
  EXPECT_EQ(seen[1], std::vector<std::int64_t>({1, 2, 3}));
  EXPECT_EQ(corrections_seen[1], 1u);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
