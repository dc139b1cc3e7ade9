#include "dypho/mapping/compute_device.h"

namespace dypho {
namespace mapping {

const char* toString(ComputeDevice device) {
  return device == ComputeDevice::kCuda ? "cuda" : "cpu";
}

#ifdef DYPHO_HAVE_CUDA
bool builtWithCuda() { return true; }
// cudaDeviceCount() is defined in src/cuda/cuda_device.cu.
#else
bool builtWithCuda() { return false; }

int cudaDeviceCount(std::string* reason) {
  if (reason != nullptr) {
    *reason = "dypho_mapping was built without CUDA (no nvcc found at configure time, or "
              "DYPHO_WITH_CUDA=OFF)";
  }
  return 0;
}
#endif

ComputeDevice selectComputeDevice(bool use_gpu, std::string* message) {
  std::string text;
  ComputeDevice device = ComputeDevice::kCpu;
  if (!use_gpu) {
    text = "using CPU (use_gpu is false)";
  } else {
    std::string reason;
    const int count = cudaDeviceCount(&reason);
    if (count > 0) {
      device = ComputeDevice::kCuda;
      text = "using CUDA (" + std::to_string(count) + " device(s) found)";
    } else {
      text = "use_gpu is true but no CUDA device is usable, falling back to CPU: " + reason;
    }
  }
  if (message != nullptr) *message = text;
  return device;
}

}  // namespace mapping
}  // namespace dypho
