#!/bin/bash
# Builds the ROS-free cores, tools and unit tests with plain CMake (no catkin, no ROS: the
# dependency check of the cores) under AddressSanitizer + UndefinedBehaviorSanitizer, and runs
# the unit tests; any sanitizer report fails the run. The whole-system dataset runs
# (test_datasets) are left to the optimised build in scripts/test.sh.
# Usage: test_sanitized.sh [BUILD_DIR]
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build-sanitized}"
JOBS="${DYPHO_JOBS:-$(nproc)}"
FLAGS="-O1 -g -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
mkdir -p "$BUILD"
cmake -S "$ROOT" -B "$BUILD" -DDYPHO_WITH_ROS=OFF -DDYPHO_WITH_CUDA=OFF -DCMAKE_BUILD_TYPE=None \
      -DDYPHO_TEST_TIMEOUT_SCALE=4 \
      -DCMAKE_CXX_FLAGS="$FLAGS" -DCMAKE_C_FLAGS="$FLAGS" \
      -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
      -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" > "$BUILD/configure.log" 2>&1 \
  || { cat "$BUILD/configure.log"; exit 1; }
# The cores must not include ROS headers (checked by building them without ROS) ...
if grep -rlE '#include <(ros|sensor_msgs|cv_bridge|tf2|nodelet)/' "$ROOT"/dypho_*/src/core "$ROOT"/dypho_*/include \
     "$ROOT"/dypho_pipeline/src 2>/dev/null; then
  echo "test_sanitized.sh: a core includes a ROS header (files above)" >&2
  exit 1
fi
cmake --build "$BUILD" -j "$JOBS"
cd "$BUILD"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Two (JOBS) at a time: the unit tests are mostly single-threaded, and under the sanitizers they
# took 15 of the suite's 50 minutes one at a time on 2 cores. test_dypho_pipeline runs alone after
# them: its realtime-runner tests play frames at their stamps.
status=0
ctest --output-on-failure -j "$JOBS" --timeout 4800 -E "^(test_datasets|test_dypho_pipeline)$" || status=1
ctest --output-on-failure -j 1 --timeout 4800 -R "^test_dypho_pipeline$" || status=1
exit "$status"
