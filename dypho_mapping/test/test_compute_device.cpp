#include <gtest/gtest.h>

#include <cstdio>
#include <stdexcept>
#include <string>

#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/cuda_rasterizer.h"
#include "dypho/mapping/cuda_trainer.h"

namespace dypho {
namespace mapping {
namespace DYPHO_UNITY_ID {

TEST(ComputeDevice, CpuWhenCpuRequested) {
  std::string message;
  EXPECT_EQ(selectComputeDevice("cpu", &message), ComputeDevice::kCpu);
  EXPECT_NE(message.find("device: cpu"), std::string::npos) << message;
}

TEST(ComputeDevice, UnknownDeviceIsAnError) {
  EXPECT_THROW(selectComputeDevice("gpu"), std::invalid_argument);
  EXPECT_THROW(selectComputeDevice(""), std::invalid_argument);
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

TEST(ComputeDevice, AutoFallsBackToCpuWithReasonWithoutDeviceAndCudaIsThenAnError) {
  std::string reason;
  const int count = cudaDeviceCount(&reason);
  std::string message;
  const ComputeDevice device = selectComputeDevice("auto", &message);
  std::printf("[ report ] built with CUDA: %s, devices: %d, selectComputeDevice(auto): %s (%s)\n",
              builtWithCuda() ? "yes" : "no", count, toString(device), message.c_str());
  if (count == 0) {
    EXPECT_EQ(device, ComputeDevice::kCpu);
    EXPECT_FALSE(reason.empty());
    EXPECT_NE(message.find("on the CPU"), std::string::npos) << message;
    EXPECT_NE(message.find(reason), std::string::npos) << message;
    // Asked for explicitly, CUDA without a device is an error, and so are the CUDA classes.
    EXPECT_THROW(selectComputeDevice("cuda"), std::runtime_error);
    EXPECT_THROW(CudaRasterizer rasterizer, std::runtime_error);
    EXPECT_THROW(CudaTrainer trainer, std::runtime_error);
  } else {
    EXPECT_TRUE(builtWithCuda());
    EXPECT_EQ(device, ComputeDevice::kCuda);
    EXPECT_EQ(selectComputeDevice("cuda"), ComputeDevice::kCuda);
  }
}

}  // namespace DYPHO_UNITY_ID
}  // namespace mapping
}  // namespace dypho
