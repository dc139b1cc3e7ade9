#!/bin/bash
# Builds the package with plain CMake at the repository root (catkin's devel space ends up in
# build/devel; `source build/devel/setup.bash` to use roslaunch/rosrun).
# Usage: build.sh [BUILD_DIR [TARGET...]]
#   no TARGET: everything a user runs (nodelets, tools), then the test executables and the
#              benchmark programs (DYPHO_SKIP_TESTS=1 leaves those out);
#   TARGET...: only those targets and what they link (scripts/demo.sh builds its two tools).
# Works from any clone path (long ones, spaces); the build folder may be anywhere.
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH   # a python first on PATH (pyenv, conda) breaks catkin
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; exit 0; fi
BUILD="${1:-$ROOT/build}"
# Absolute: a relative folder (`build.sh build`) hides the spaces of the path it lies in.
mkdir -p "$BUILD" && BUILD="$(cd "$BUILD" && pwd)"
TARGETS=("${@:2}")
JOBS="${DYPHO_JOBS:-$(nproc)}"
CONFIG=(-DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3)
# DYPHO_STRICT=1 (set by test.sh when CI=true): catkin and the generated test models are required.
if [ "${DYPHO_STRICT:-0}" = "1" ]; then CONFIG+=(-DDYPHO_STRICT=ON); fi
# DYPHO_CUDA: on (default: the CUDA code is compiled whenever nvcc is there, so it keeps
# compiling on every machine), off, or gpu (only when a GPU is visible to nvidia-smi: what the
# demo uses, since without a GPU the CUDA path cannot run; it saves about a minute of build).
case "${DYPHO_CUDA:-on}" in
  on) CUDA=ON ;;
  off) CUDA=OFF ;;
  gpu) if nvidia-smi -L > /dev/null 2>&1; then CUDA=ON; else CUDA=OFF; fi ;;
  *) echo "build: DYPHO_CUDA must be on, off or gpu (got '$DYPHO_CUDA')" >&2; exit 2 ;;
esac
CONFIG+=(-DDYPHO_WITH_CUDA=$CUDA)
if [ "$CUDA" = ON ] && [ -x /usr/local/cuda/bin/nvcc ]; then CONFIG+=(-DCMAKE_CUDA_COMPILER=/usr/local/cuda/bin/nvcc); fi
# The GPU architectures compiled for (CMake's list): the five of cmake/dypho_cuda.cmake unless
# DYPHO_CUDA_ARCHITECTURES names others ("native": this machine's GPU). Passed every time, so that
# a build folder configured once with other ones comes back to the default.
CONFIG+=(-DCMAKE_CUDA_ARCHITECTURES="${DYPHO_CUDA_ARCHITECTURES:-75;80;86;89;90}")
# rostest gives each test node its result file as an unquoted argument (rostest/runner.py): with
# a space in the build path that file is never written and every rostest fails. catkin's test
# results then go to a folder without spaces, one per build folder.
if [[ "$BUILD" =~ [[:space:]] ]]; then
  CONFIG+=(-DCATKIN_TEST_RESULTS_DIR="${TMPDIR:-/tmp}/dypho-test-results-$(printf '%s' "$BUILD" | md5sum | cut -c1-12)")
fi
# Configure twice: catkin caches an empty PYTHONPATH in setup_cached.sh on the first configure.
LOG="$BUILD/configure.log"
cmake -S "$ROOT" -B "$BUILD" "${CONFIG[@]}" > "$LOG" 2>&1 || { cat "$LOG"; exit 1; }
cmake -S "$ROOT" -B "$BUILD" "${CONFIG[@]}" >> "$LOG" 2>&1 || { cat "$LOG"; exit 1; }
if [ ${#TARGETS[@]} -gt 0 ]; then
  cmake --build "$BUILD" -j "$JOBS" --target "${TARGETS[@]}"
  echo "build: ${TARGETS[*]} done in $BUILD"
  exit 0
fi
cmake --build "$BUILD" -j "$JOBS"
# Test executables, their generated inputs and the benchmark programs are not part of `all`;
# DYPHO_SKIP_TESTS=1 leaves them out.
if [ "${DYPHO_SKIP_TESTS:-0}" != "1" ]; then
  cmake --build "$BUILD" -j "$JOBS" --target tests benches
fi
echo "build: done in $BUILD (source $BUILD/devel/setup.bash for roslaunch)"
