#!/bin/bash
# Installs what is needed, builds the two tools it runs, and runs DyPho-SLAM on the built-in
# default input: a synthetic room with two people walking and a camera moving on a half sphere
# (generated deterministically). Prints a line per stage, then the ATE and where the outputs are.
# Usage: demo.sh [OUT_DIR]   (default: out/ in the clone; works from any clone path)
#   DYPHO_BUILD_DIR: the build folder (default: build/ in the clone)
set -euo pipefail
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; exit 0; fi
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${1:-$ROOT/out}"
BUILD="${DYPHO_BUILD_DIR:-$ROOT/build}"
mkdir -p "$OUT" "$BUILD"
stage() { echo "demo: [$1/4, $SECONDS s] $2"; }

stage 1 "installing the Debian packages (nothing to do when they are there)"
bash "$ROOT/scripts/install_deps.sh"
stage 2 "building dypho_synth and dypho_run_dataset in $BUILD (about 3.5 min on 2 cores the first time)"
# The whole log goes to a file; the terminal gets one line per tenth of the build.
if ! DYPHO_CUDA="${DYPHO_CUDA:-gpu}" bash "$ROOT/scripts/build.sh" "$BUILD" dypho_synth dypho_run_dataset 2>&1 | tee "$BUILD/demo-build.log" |
     awk 'BEGIN { part = 1 }
          match($0, /^\[ *[0-9]+%\]/) { p = substr($0, 2, RLENGTH - 3) + 0;
          if (p < last) { part++; next_p = 0 }  # make reports each of the two targets from 0 %
          last = p
          if (p >= next_p) { printf "demo:   build, target %d of 2: %d%%\n", part, p; fflush(); next_p = p - p % 10 + 10 } }'; then
  tail -40 "$BUILD/demo-build.log"; echo "demo: the build failed; the whole log: $BUILD/demo-build.log" >&2; exit 1
fi
BIN="$BUILD/devel/lib/dypho_slam"
[ -x "$BIN/dypho_run_dataset" ] || BIN="$BUILD/tools"   # plain CMake without catkin
stage 3 "generating the input: 200 frames, two people walking ($OUT/synthetic)"
"$BIN/dypho_synth" --out "$OUT/synthetic" --frames 200 --motion halfsphere --people 2 --seed 1 > "$OUT/synth.log" 2>&1 ||
  { cat "$OUT/synth.log"; exit 1; }
stage 4 "running mask, tracking and mapping on it ($OUT/run; a progress line follows)"
"$BIN/dypho_run_dataset" --dataset "$OUT/synthetic" --out "$OUT/run"
echo
echo "demo: done in $SECONDS s"
echo "Input:   $OUT/synthetic (TUM layout; also synthetic.bag when built with ROS)"
echo "Outputs: $OUT/run (trajectory.txt, trajectory.png, map.ply, map.pcd, evaluation.txt)"
echo "Replay the bag in rviz: bash scripts/build.sh && source $BUILD/devel/setup.bash &&"
echo "         roslaunch dypho_slam tum_bag.launch bag:=$OUT/synthetic/synthetic.bag rviz:=true \\"
echo "           rolling_shutter_readout_ms:=0   # the generator's camera has a global shutter"
