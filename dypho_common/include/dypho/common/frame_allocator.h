#pragma once
/// \file frame_allocator.h
/// Keeps frame-sized buffers (images, depth, flow, masks, distance maps: 0.3-4 MB each, allocated
/// and freed on every frame) inside the process. With glibc's defaults such a buffer is often
/// handed back to the kernel when it is freed (above the mmap threshold, or at the top of a
/// thread's heap beyond the trim threshold) and faulted in again page by page on the next frame.
/// On the 2-core CI VM those page faults were 18 % of the feature thread's time in the live graph
/// (docs/journal/benchmarks-2026.md, section 6). The cost: the process keeps up to 256 MB per heap it
/// freed, instead of returning them.

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <string>

namespace dypho {

/// Process-wide (glibc's allocator): buffers up to 32 MB (glibc's largest mmap threshold) come
/// from the heaps, and freed heap memory is only returned beyond 256 MB. Call it once at start
/// (nodelets: onInit; more calls change nothing). Returns an empty string on success, else why
/// not (another allocator, e.g. a sanitizer's, or not glibc); nothing else changes then.
inline std::string keepFrameBuffersInProcess() {
#if defined(__GLIBC__)
  constexpr int kMmapThresholdBytes = 32 * 1024 * 1024;
  constexpr int kTrimThresholdBytes = 256 * 1024 * 1024;
  if (mallopt(M_MMAP_THRESHOLD, kMmapThresholdBytes) != 1 || mallopt(M_TRIM_THRESHOLD, kTrimThresholdBytes) != 1) {
    return "mallopt refused the thresholds (another allocator in use?)";
  }
  return {};
#else
  return "not glibc: the allocator keeps its defaults";
#endif
}

}  // namespace dypho
