#pragma once
/// \file compute_device.h
/// Choice between the CPU and the CUDA implementation of the mapping operations.
///
/// The CPU path is always built and is the reference; CUDA code is compiled only when the build
/// found nvcc (compile definition DYPHO_HAVE_CUDA=1 on dypho_mapping_core and its users).

#include <string>

namespace dypho {
namespace mapping {

/// Where mapping operations run.
enum class ComputeDevice { kCpu, kCuda };

/// "cpu" or "cuda".
const char* toString(ComputeDevice device);

/// True when this library was built with CUDA support.
bool builtWithCuda();

/// Number of usable CUDA devices; 0 when not built with CUDA, when no driver is installed or no
/// device is present. Never throws. When 0 and `reason` is given, it receives the CUDA runtime's
/// explanation (or "not built with CUDA").
int cudaDeviceCount(std::string* reason = nullptr);

/// Picks the device for a run from GaussianMapperOptions::device: "cpu" -> kCpu; "cuda" -> kCuda
/// when the build has CUDA and a device is present, else throws std::runtime_error saying why;
/// "auto" -> kCuda when possible, else kCpu. Other values throw std::invalid_argument.
/// `message` (optional) receives one line saying what was chosen and, for a fallback, why (to be
/// logged once by the caller).
ComputeDevice selectComputeDevice(const std::string& requested, std::string* message = nullptr);

}  // namespace mapping
}  // namespace dypho
