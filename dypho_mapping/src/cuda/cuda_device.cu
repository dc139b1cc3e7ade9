// CUDA device query for dypho_mapping (compiled only when DYPHO_HAVE_CUDA).
#include <cuda_runtime.h>

#include <string>

#include "dypho/mapping/compute_device.h"

namespace dypho {
namespace mapping {

int cudaDeviceCount(std::string* reason) {
  int count = 0;
  const cudaError_t err = cudaGetDeviceCount(&count);
  if (err != cudaSuccess) {
    (void)cudaGetLastError();  // clear the sticky-free error state of the runtime
    if (reason != nullptr) {
      *reason = std::string("CUDA runtime: ") + cudaGetErrorName(err) + ": " + cudaGetErrorString(err);
    }
    return 0;
  }
  if (count == 0 && reason != nullptr) *reason = "CUDA runtime reports 0 devices";
  return count;
}

}  // namespace mapping
}  // namespace dypho
