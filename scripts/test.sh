#!/bin/bash
# Installs what is needed, builds, and runs the whole test suite: unit tests, rostests, the
# dataset runs on ../shared; then the cores' unit tests again under ASan + UBSan (plain CMake, no
# ROS) and a short run of the libFuzzer targets. Exit code 0 only when every part passed.
set -euo pipefail
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then
  sed -n '2,4p' "$0" | sed 's/^# \{0,1\}//'
  echo "Environment: CI=true (strict: ../shared and every generated input required), DYPHO_BUILD_DIR,"
  echo "DYPHO_SHARED_DIR, DYPHO_JOBS, DYPHO_FUZZ_SECONDS (default 20)."
  exit 0
fi
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${DYPHO_BUILD_DIR:-$ROOT/build}"
# In CI (CI=true) nothing may be quietly left out: the shared real data must be there, and the
# build is strict (DYPHO_STRICT: catkin/ROS and the generated test models are required).
if [ "${CI:-}" = "true" ]; then
  SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
  for needed in "$SHARED/data/tum_fr1_rpy_first150" "$SHARED/data/rgbd_bonn_crowd_frames200to399" \
                "$SHARED/models/yolox_nano.onnx"; do
    if [ ! -e "$needed" ]; then
      echo "test.sh: CI=true but $needed is missing (../shared must sit beside the repository)" >&2
      exit 1
    fi
  done
  export DYPHO_STRICT=1
fi
# How long each part took, printed as it ends (the suite's budget is 45 minutes on 2 cores).
phase_start=$SECONDS
phase_done() { echo "test.sh: $1 took $((SECONDS - phase_start)) s"; phase_start=$SECONDS; }
bash "$ROOT/scripts/install_deps.sh"
phase_done "install"
bash "$ROOT/scripts/build.sh" "$BUILD"
phase_done "build"
cd "$BUILD"
# rostest starts its own roscore on a free port; ROS_HOME keeps logs inside the build folder.
export ROS_HOME="$BUILD/ros_home"
status=0
ctest --output-on-failure -j 1 --timeout 1200 || status=$?
phase_done "ctest"
# docs/results.md and the README's results table are generated from docs/results/rows.tsv.
/usr/bin/python3 "$ROOT/scripts/results_table.py" --check || status=1
# docs/parameters.md lists every core parameter with the default of config/*.yaml.
/usr/bin/python3 "$ROOT/scripts/check_parameters_doc.py" || status=1
# The code's form: clang-format (.clang-format), and functions and files within their size.
bash "$ROOT/scripts/check_format.sh" || status=1
bash "$ROOT/scripts/check_code_size.sh" || status=1
# What failed, and the failures' own lines (gtest assertions, the rostest nodes' summaries from
# their logs under ROS_HOME): printed again at the very end, where a shortened log still shows it.
failure_summary="$BUILD/failure_summary.txt"
: > "$failure_summary"
if [ -s Testing/Temporary/LastTestsFailed.log ]; then
  {
    echo "test.sh: ctest tests that failed:"
    sed 's/^/  /' Testing/Temporary/LastTestsFailed.log
    echo "test.sh: their failures (gtest assertions, and the rostest nodes' logs that hold one):"
    { grep -hE -A2 ": Failure$" Testing/Temporary/LastTest.log || true; } | cut -c1-300 | head -40 | sed 's/^/  /'
    for log in $(grep -l ": Failure$" "$ROS_HOME"/log/*/*-stdout.log 2>/dev/null || true); do
      echo "  -- $(basename "$log")"
      { grep -hE -A2 ": Failure$|^(live test|graph test|in process|graph vs)" "$log" || true; } | cut -c1-300 | head -40 | sed 's/^/    /'
    done
  } > "$failure_summary" || true
fi
# Skipped tests (ctest lists them as "Not Run"/"Skipped"): show why, from the test output.
if grep -q ": Skipped$" Testing/Temporary/LastTest.log 2>/dev/null; then
  echo "test.sh: tests that skipped themselves, and why:"
  grep -h -A1 ": Skipped$" Testing/Temporary/LastTest.log | grep -v -- "^--$" | sed 's/^/  /'
fi
# The standalone mapping build (rasterizers and CUDA parity tests without ROS/OpenCV, what a GPU
# machine builds: scripts/gpu_check.sh): it must keep compiling, CUDA included where nvcc exists.
STANDALONE="$BUILD-standalone"
{ cmake -S "$ROOT/dypho_mapping/standalone" -B "$STANDALONE" > "$BUILD/standalone-configure.log" 2>&1 &&
  cmake --build "$STANDALONE" -j "${DYPHO_JOBS:-$(nproc)}" > "$BUILD/standalone-build.log" 2>&1 &&
  (cd "$STANDALONE" && ctest --output-on-failure); } || { echo "test.sh: standalone mapping build or tests failed (logs in $BUILD)"; status=1; }
phase_done "standalone mapping build and tests"
# The ROS-free cores and unit tests again, built with plain CMake under ASan + UBSan (leaks too),
# then a short run of each libFuzzer target on its seed corpus (longer runs: scripts/fuzz.sh).
bash "$ROOT/scripts/test_sanitized.sh" "$BUILD-sanitized" || status=1
phase_done "sanitized build and tests"
bash "$ROOT/scripts/fuzz.sh" "${DYPHO_FUZZ_SECONDS:-20}" "$BUILD-fuzz" || status=1
phase_done "fuzzing"
[ ! -s "$failure_summary" ] || cat "$failure_summary"
echo "test.sh: all parts took $SECONDS s"
exit "$status"
