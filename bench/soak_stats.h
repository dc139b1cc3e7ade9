#pragma once
/// \file soak_stats.h
/// The measurements the soak programs (soak_runner, graph_soak_probe) share.
#include <algorithm>
#include <fstream>
#include <sstream>
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

/// User + system CPU time [s] of the process whose stat file is `stat_path` (/proc/PID/stat);
/// negative when it cannot be read.
inline double cpuSeconds(const std::string& stat_path) {
  std::ifstream stat(stat_path);
  std::string line;
  if (!std::getline(stat, line)) return -1.0;
  // Fields after the command name (which may hold spaces) start after the last ')'.
  const std::size_t close = line.rfind(')');
  if (close == std::string::npos) return -1.0;
  std::istringstream rest(line.substr(close + 1));
  std::string field;
  double utime = 0, stime = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {  // field 3 is the state; 14 utime, 15 stime
    if (i == 14) utime = std::stod(field);
    if (i == 15) stime = std::stod(field);
  }
  return (utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

/// The `p` quantile (0..1, nearest rank) of `v`; 0 for an empty list.
inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace dypho::bench
