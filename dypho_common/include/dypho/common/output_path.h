#pragma once
/// \file output_path.h
/// Where a service may write: requests name a folder inside the configured output directory,
/// never a path outside it (a ROS 1 service can be called by anyone on the network).

#include <filesystem>
#include <stdexcept>
#include <string>

namespace dypho {

/// The folder `requested` inside `base_dir`: empty = `base_dir` itself; relative = below it;
/// absolute = accepted only when it lies inside `base_dir`. `..` that leaves `base_dir`, or an
/// absolute path elsewhere, throws std::invalid_argument naming both. Symbolic links are resolved
/// as far as the path exists. Creates nothing.
inline std::string resolveOutputDirectory(const std::string& base_dir, const std::string& requested) {
  namespace fs = std::filesystem;
  if (base_dir.empty()) throw std::invalid_argument("no output directory configured");
  const fs::path base = fs::weakly_canonical(fs::absolute(base_dir));
  const fs::path wanted = requested.empty()                   ? base
                          : fs::path(requested).is_absolute() ? fs::weakly_canonical(fs::path(requested))
                                                              : fs::weakly_canonical(base / requested);
  const fs::path relative = wanted.lexically_relative(base);
  if (relative.empty() || *relative.begin() == "..") {
    throw std::invalid_argument("'" + requested + "' is outside the output directory '" + base.string() +
                                "': name a folder inside it (relative paths are taken from there)");
  }
  return wanted.string();
}

}  // namespace dypho
