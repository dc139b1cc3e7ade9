#pragma once
/// \file soak_stats.h
/// The two measurements the soak programs (soak_runner, graph_soak_probe) share.
#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace dypho::bench {

/// Resident memory [MB] of the process whose statm file is `statm_path` (/proc/self/statm,
/// /proc/PID/statm); 0 when it cannot be read.
inline double residentMb(const std::string& statm_path) {
  std::ifstream statm(statm_path);
  long pages_total = 0, pages_resident = 0;
  if (!(statm >> pages_total >> pages_resident)) return 0.0;
  return static_cast<double>(pages_resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

/// The `p` quantile (0..1, nearest rank) of `v`; 0 for an empty list.
inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace dypho::bench
