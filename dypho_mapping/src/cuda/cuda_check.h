#pragma once
/// \file cuda_check.h
/// Checked CUDA calls and grow-only device buffers (nvcc-only header of src/cuda).

#include <cuda_runtime.h>

#include <cstddef>
#include <stdexcept>
#include <string>

namespace dypho::mapping::cuda {

/// Throws std::runtime_error naming the call, the place and the CUDA error when `err` is not
/// cudaSuccess (and clears the runtime's last error).
inline void check(cudaError_t err, const char* call, const char* file, int line) {
  if (err == cudaSuccess) return;
  (void)cudaGetLastError();
  throw std::runtime_error(std::string("CUDA error in ") + call + " (" + file + ":" + std::to_string(line) +
                           "): " + cudaGetErrorName(err) + ": " + cudaGetErrorString(err));
}

/// Device array that only grows (by at least half its size, contents not kept): sizes reached
/// once are never allocated again.
template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  ~DeviceBuffer() {
    if (ptr_ != nullptr) cudaFree(ptr_);
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  /// Room for `n` elements; returns the array.
  T* reserve(std::size_t n);
  /// Room for `n` elements, keeping the first `keep` (<= current capacity) elements.
  T* reserveKeep(std::size_t n, std::size_t keep, cudaStream_t stream);
  T* get() const { return ptr_; }
  void swap(DeviceBuffer& other) {
    T* p = ptr_;
    ptr_ = other.ptr_;
    other.ptr_ = p;
    const std::size_t c = capacity_;
    capacity_ = other.capacity_;
    other.capacity_ = c;
  }
  std::size_t capacity() const { return capacity_; }

 private:
  T* ptr_ = nullptr;
  std::size_t capacity_ = 0;
};

}  // namespace dypho::mapping::cuda

#define DYPHO_CUDA_CHECK(call) ::dypho::mapping::cuda::check((call), #call, __FILE__, __LINE__)
/// After a kernel launch: launch errors (bad configuration, no kernel image for this GPU).
#define DYPHO_CUDA_CHECK_LAUNCH(kernel) \
  ::dypho::mapping::cuda::check(cudaGetLastError(), "launch of " kernel, __FILE__, __LINE__)

namespace dypho::mapping::cuda {

template <typename T>
T* DeviceBuffer<T>::reserve(std::size_t n) {
  if (n <= capacity_ && ptr_ != nullptr) return ptr_;
  const std::size_t want = n > capacity_ + capacity_ / 2 ? n : capacity_ + capacity_ / 2;
  if (ptr_ != nullptr) DYPHO_CUDA_CHECK(cudaFree(ptr_));
  ptr_ = nullptr;
  capacity_ = 0;
  DYPHO_CUDA_CHECK(cudaMalloc(reinterpret_cast<void**>(&ptr_), (want > 0 ? want : 1) * sizeof(T)));
  capacity_ = want > 0 ? want : 1;
  return ptr_;
}

template <typename T>
T* DeviceBuffer<T>::reserveKeep(std::size_t n, std::size_t keep, cudaStream_t stream) {
  if (n <= capacity_ && ptr_ != nullptr) return ptr_;
  const std::size_t want = n > capacity_ + capacity_ / 2 ? n : capacity_ + capacity_ / 2;
  T* fresh = nullptr;
  DYPHO_CUDA_CHECK(cudaMalloc(reinterpret_cast<void**>(&fresh), (want > 0 ? want : 1) * sizeof(T)));
  if (ptr_ != nullptr) {
    if (keep > 0) {
      DYPHO_CUDA_CHECK(cudaMemcpyAsync(fresh, ptr_, keep * sizeof(T), cudaMemcpyDeviceToDevice, stream));
      DYPHO_CUDA_CHECK(cudaStreamSynchronize(stream));
    }
    DYPHO_CUDA_CHECK(cudaFree(ptr_));
  }
  ptr_ = fresh;
  capacity_ = want > 0 ? want : 1;
  return ptr_;
}

}  // namespace dypho::mapping::cuda
