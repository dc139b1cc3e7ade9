#!/bin/bash
# Installs what is needed, builds, and runs DyPho-SLAM on the built-in default input: a synthetic
# room with two people walking and a camera moving on a half sphere (generated deterministically).
# Prints where the outputs are and the ATE. Usage: demo.sh [OUT_DIR]
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${1:-$ROOT/out}"
bash "$ROOT/scripts/install_deps.sh"
DYPHO_SKIP_TESTS=1 bash "$ROOT/scripts/build.sh" "$ROOT/build"
BIN="$ROOT/build/devel/lib/dypho_slam"
"$BIN/dypho_synth" --out "$OUT/synthetic" --frames 300 --motion halfsphere --people 2 --seed 1
"$BIN/dypho_run_dataset" --dataset "$OUT/synthetic" --out "$OUT/run"
echo
echo "Input:   $OUT/synthetic (TUM layout + synthetic.bag; replay with"
echo "         roslaunch dypho_slam tum_bag.launch bag:=$OUT/synthetic/synthetic.bag rviz:=true)"
echo "Outputs: $OUT/run"
