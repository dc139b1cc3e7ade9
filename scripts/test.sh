#!/bin/bash
# Installs what is needed, builds, and runs the whole test suite (unit tests, the rostest graph
# test, the dataset runs on ../shared when present). Exit code 0 only when every test passed.
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${DYPHO_BUILD_DIR:-$ROOT/build}"
bash "$ROOT/scripts/install_deps.sh"
bash "$ROOT/scripts/build.sh" "$BUILD"
cd "$BUILD"
# rostest starts its own roscore on a free port; ROS_HOME keeps logs inside the build folder.
export ROS_HOME="$BUILD/ros_home"
ctest --output-on-failure -j 1 --timeout 1200
