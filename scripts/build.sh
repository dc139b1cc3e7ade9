#!/bin/bash
# Builds the package with plain CMake at the repository root (catkin's devel space ends up in
# build/devel; `source build/devel/setup.bash` to use roslaunch/rosrun). Usage: build.sh [BUILD_DIR]
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH   # a python first on PATH (pyenv, conda) breaks catkin
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
JOBS="${DYPHO_JOBS:-$(nproc)}"
CONFIG=(-DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3)
# DYPHO_STRICT=1 (set by test.sh when CI=true): catkin and the generated test models are required.
if [ "${DYPHO_STRICT:-0}" = "1" ]; then CONFIG+=(-DDYPHO_STRICT=ON); fi
if [ -x /usr/local/cuda/bin/nvcc ]; then CONFIG+=(-DCMAKE_CUDA_COMPILER=/usr/local/cuda/bin/nvcc); fi
# Configure twice: catkin caches an empty PYTHONPATH in setup_cached.sh on the first configure.
mkdir -p "$BUILD"
LOG="$BUILD/configure.log"
cmake -S "$ROOT" -B "$BUILD" "${CONFIG[@]}" > "$LOG" 2>&1 || { cat "$LOG"; exit 1; }
cmake -S "$ROOT" -B "$BUILD" "${CONFIG[@]}" >> "$LOG" 2>&1 || { cat "$LOG"; exit 1; }
cmake --build "$BUILD" -j "$JOBS"
# Test executables (catkin keeps them out of `all`); DYPHO_SKIP_TESTS=1 skips them.
if [ "${DYPHO_SKIP_TESTS:-0}" != "1" ]; then
  cmake --build "$BUILD" -j "$JOBS" --target tests
fi
echo "build: done in $BUILD (source $BUILD/devel/setup.bash for roslaunch)"
