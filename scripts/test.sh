#!/bin/bash
# Installs what is needed, builds, and runs the whole test suite: unit tests, rostests, the
# dataset runs on ../shared; then the cores' unit tests again under ASan + UBSan (plain CMake, no
# ROS) and a short run of the libFuzzer targets. Exit code 0 only when every part passed.
set -euo pipefail
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then
  sed -n '2,4p' "$0" | sed 's/^# \{0,1\}//'
  echo "Environment: CI=true (strict: ../shared and every generated input required), DYPHO_BUILD_DIR,"
  echo "DYPHO_SHARED_DIR, DYPHO_JOBS, DYPHO_FUZZ_SECONDS (default 16), DYPHO_CUDA_ARCHITECTURES (default:"
  echo "this machine's GPU, else 75)."
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
# The CUDA code is compiled for one GPU architecture here (the product's build, scripts/build.sh,
# compiles five): this machine's GPU where there is one, for the parity tests, else the oldest
# (7.5), to check that it compiles; the code has no architecture-specific branches. The five
# were about 40 more compile-seconds of the build on 2 cores.
if [ -z "${DYPHO_CUDA_ARCHITECTURES:-}" ]; then
  if nvidia-smi -L > /dev/null 2>&1; then export DYPHO_CUDA_ARCHITECTURES=native; else export DYPHO_CUDA_ARCHITECTURES=75; fi
fi
bash "$ROOT/scripts/build.sh" "$BUILD"
phase_done "build"
cd "$BUILD"
# rostest starts its own roscore on a free port; ROS_HOME keeps logs inside the build folder.
export ROS_HOME="$BUILD/ros_home"
status=0
# ctest keeps the failed and the full log of its last call only: each call's are added up here.
failed_tests="$BUILD/ctest_failed.log"
ctest_log="$BUILD/ctest_output.log"
: > "$failed_tests"
: > "$ctest_log"
run_ctest() {
  rm -f Testing/Temporary/LastTestsFailed.log
  ctest --output-on-failure --timeout 1200 "$@" || status=1
  cat Testing/Temporary/LastTestsFailed.log >> "$failed_tests" 2>/dev/null || true
  cat Testing/Temporary/LastTest.log >> "$ctest_log" 2>/dev/null || true
}
# The unit tests two at a time (those that keep both cores busy never side by side: ALL_CORES in
# cmake/dypho_helpers.cmake); they took 207 s one at a time on 2 cores. The pipeline's realtime
# runs (frames played at their stamps) then run alone, and the rest one at a time: rostests and
# launch tests play at real time, and the dataset runs keep both cores busy.
GTEST_FILTER="-RealtimeRunner.*" run_ctest -j 2 -L '^unit$'
GTEST_FILTER="RealtimeRunner.*" run_ctest -j 1 -R '^test_dypho_pipeline$'
run_ctest -j 1 -LE '^unit$'
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
if [ -s "$failed_tests" ]; then
  {
    echo "test.sh: ctest tests that failed:"
    sed 's/^/  /' "$failed_tests"
    echo "test.sh: their failures (gtest assertions, and the rostest nodes' logs that hold one):"
    { grep -hE -A2 ": Failure$" "$ctest_log" || true; } | cut -c1-300 | head -40 | sed 's/^/  /'
    # One log name per line (the workspace path may hold spaces).
    { grep -l ": Failure$" "$ROS_HOME"/log/*/*-stdout.log 2>/dev/null || true; } | while IFS= read -r log; do
      echo "  -- $(basename "$log")"
      { grep -hE -A2 ": Failure$|^(live test|graph test|in process|graph vs)" "$log" || true; } | cut -c1-300 | head -40 | sed 's/^/    /'
    done
  } > "$failure_summary" || true
fi
# Skipped tests (ctest lists them as "Not Run"/"Skipped"): show why, from the test output.
if grep -q ": Skipped$" "$ctest_log" 2>/dev/null; then
  echo "test.sh: tests that skipped themselves, and why:"
  grep -h -A1 ": Skipped$" "$ctest_log" | grep -v -- "^--$" | sed 's/^/  /'
fi
# The standalone mapping build (rasterizers and CUDA parity tests without ROS/OpenCV, what a GPU
# machine builds: scripts/gpu_check.sh): it must keep compiling, CUDA included where nvcc exists.
# Its CUDA files are the package's, which the build above compiled for all five architectures:
# here one (the oldest, 7.5) checks that the standalone build compiles and links them (about 45 s
# less than five).
STANDALONE="$BUILD-standalone"
{ cmake -S "$ROOT/dypho_mapping/standalone" -B "$STANDALONE" -DCMAKE_CUDA_ARCHITECTURES=75 \
    > "$BUILD/standalone-configure.log" 2>&1 &&
  cmake --build "$STANDALONE" -j "${DYPHO_JOBS:-$(nproc)}" > "$BUILD/standalone-build.log" 2>&1 &&
  (cd "$STANDALONE" && ctest --output-on-failure); } || { echo "test.sh: standalone mapping build or tests failed (logs in $BUILD)"; status=1; }
phase_done "standalone mapping build and tests"
# The ROS-free cores and unit tests again, built with plain CMake under ASan + UBSan (leaks too),
# then a short run of each libFuzzer target on its seed corpus (longer runs: scripts/fuzz.sh).
bash "$ROOT/scripts/test_sanitized.sh" "$BUILD-sanitized" || status=1
phase_done "sanitized build and tests"
bash "$ROOT/scripts/fuzz.sh" "${DYPHO_FUZZ_SECONDS:-16}" "$BUILD-fuzz" || status=1
phase_done "fuzzing"
[ ! -s "$failure_summary" ] || cat "$failure_summary"
echo "test.sh: all parts took $SECONDS s"
exit "$status"
