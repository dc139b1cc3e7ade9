#pragma once
/// \file atomic_file.h
/// Write a file so that readers see either the old or the complete new content, never a prefix.

#include <cstdio>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>

#include <fcntl.h>
#include <unistd.h>

namespace dypho {

/// Calls `write(stream)` on a temporary file next to `path`, flushes it, then renames it over
/// `path`. Throws std::runtime_error naming the path when any step fails; the temporary file is
/// removed on failure.
inline void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                                bool binary = false) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp,
                      binary ? std::ios::out | std::ios::binary | std::ios::trunc : std::ios::out | std::ios::trunc);
    if (!out) {
      throw std::runtime_error("cannot open '" + tmp + "' for writing (does the folder exist, is it writable?)");
    }
    write(out);
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      throw std::runtime_error("writing '" + tmp + "' failed (disk full?)");
    }
  }
  // On disk before it replaces the old file (a crash or power cut after the rename then finds the
  // new content, not an empty file).
  const int fd = ::open(tmp.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot rename '" + tmp + "' to '" + path + "'");
  }
}

}  // namespace dypho
