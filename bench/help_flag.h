// -h / --help for the benchmark programs: the usage on stdout and exit status 0.
#pragma once

#include <cstdio>
#include <cstring>

namespace dypho::bench {

/// True (after printing `usage` on stdout) when -h or --help is among the arguments.
inline bool printHelpIfAsked(int argc, char** argv, const char* usage) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "-h") == 0 || std::strcmp(argv[i], "--help") == 0) {
      std::fputs(usage, stdout);
      return true;
    }
  }
  return false;
}

}  // namespace dypho::bench
