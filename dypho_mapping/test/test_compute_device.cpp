#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "dypho/mapping/compute_device.h"

namespace dypho {
namespace mapping {
namespace {

TEST(ComputeDevice, CpuWhenGpuNotRequested) {
  std::string message;
  EXPECT_EQ(selectComputeDevice(false, &message), ComputeDevice::kCpu);
  EXPECT_NE(message.find("use_gpu is false"), std::string::npos) << message;
}

TEST(ComputeDevice, BuildFlagMatchesCompileDefinition) {
#ifdef DYPHO_HAVE_CUDA
  EXPECT_TRUE(builtWithCuda());
#else
  EXPECT_FALSE(builtWithCuda());
#endif
}

TEST(ComputeDevice, GpuRequestFallsBackToCpuWithReasonWithoutDevice) {
  std::string reason;
  const int count = cudaDeviceCount(&reason);
  std::string message;
  const ComputeDevice device = selectComputeDevice(true, &message);
  std::printf("[ report ] built with CUDA: %s, devices: %d, selectComputeDevice(true): %s (%s)\n",
              builtWithCuda() ? "yes" : "no", count, toString(device), message.c_str());
  if (count == 0) {
    EXPECT_EQ(device, ComputeDevice::kCpu);
    EXPECT_FALSE(reason.empty());
    EXPECT_NE(message.find("falling back to CPU"), std::string::npos) << message;
    EXPECT_NE(message.find(reason), std::string::npos) << message;
  } else {
    EXPECT_TRUE(builtWithCuda());
    EXPECT_EQ(device, ComputeDevice::kCuda);
  }
}

}  // namespace
}  // namespace mapping
}  // namespace dypho
