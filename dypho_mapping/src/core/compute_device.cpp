#include "dypho/mapping/compute_device.h"

#include <stdexcept>

namespace dypho {
namespace mapping {

const char* toString(ComputeDevice device) { return device == ComputeDevice::kCuda ? "cuda" : "cpu"; }

#ifdef DYPHO_HAVE_CUDA
bool builtWithCuda() { return true; }
// cudaDeviceCount() is defined in src/cuda/cuda_device.cu.
#else
bool builtWithCuda() { return false; }

int cudaDeviceCount(std::string* reason) {
  if (reason != nullptr) {
    *reason =
        "dypho_mapping was built without CUDA (no nvcc found at configure time, or "
        "DYPHO_WITH_CUDA=OFF)";
  }
  return 0;
}
#endif

ComputeDevice selectComputeDevice(const std::string& requested, std::string* message) {
  if (requested != "auto" && requested != "cpu" && requested != "cuda") {
    throw std::invalid_argument("device must be auto, cpu or cuda (got \"" + requested + "\")");
  }
  std::string text;
  ComputeDevice device = ComputeDevice::kCpu;
  if (requested == "cpu") {
    text = "mapping on the CPU (device: cpu)";
  } else {
    std::string reason;
    const int count = cudaDeviceCount(&reason);
    if (count > 0) {
      device = ComputeDevice::kCuda;
      text = "mapping on CUDA (device: " + requested + ", " + std::to_string(count) + " device(s) found)";
    } else if (requested == "cuda") {
      throw std::runtime_error("device: cuda, but no CUDA device is usable: " + reason);
    } else {
      text = "mapping on the CPU (device: auto, no CUDA device usable: " + reason + ")";
    }
  }
  if (message != nullptr) *message = text;
  return device;
}

}  // namespace mapping
}  // namespace dypho
