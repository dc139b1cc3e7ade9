#pragma once
/// The fuzzers' input as a file: the readers under test take paths (as users give them).

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

namespace dypho::fuzz {

/// Writes `data` to a per-process temporary file and returns its path (overwritten each call).
inline std::string writeInput(const std::uint8_t* data, std::size_t size, const char* suffix) {
  const std::string path = "/tmp/dypho_fuzz_" + std::to_string(::getpid()) + suffix;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return path;
  if (size > 0) std::fwrite(data, 1, size, f);
  std::fclose(f);
  return path;
}

}  // namespace dypho::fuzz
