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

// Whether the library was built with CUDA is decided by CMake (nvcc found); the test gets that
// answer separately from the configure step (DYPHO_TEST_NVCC_FOUND), not from the library's own
// compile definition, so a library that lost its CUDA part while nvcc was there fails here.
TEST(ComputeDevice, BuiltWithCudaExactlyWhenNvccWasFound) {
  EXPECT_EQ(builtWithCuda(), DYPHO_TEST_NVCC_FOUND != 0);
  std::string reason;
  if (!builtWithCuda()) {
    EXPECT_EQ(cudaDeviceCount(&reason), 0);
    EXPECT_NE(reason.find("built without CUDA"), std::string::npos) << reason;
  }
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
