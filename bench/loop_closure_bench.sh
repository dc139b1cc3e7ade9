#!/bin/bash
# Loop closure on a synthetic closed loop (dypho_synth --motion loop, 600 frames, 9 m path, no
# people): tracking_bench_sequence with loop closure on and off, with the default settings and with
# a deliberately weak odometry (300 features, no local map, no local BA) that drifts more.
# Prints final-trajectory ATE, online ATE and the first-to-last-frame drift (the loop gap).
# Usage: bench/loop_closure_bench.sh [BUILD_DIR] [OUT_DIR]
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-/tmp/dypho_loop}"
BIN="$BUILD/devel/lib/dypho_slam"
mkdir -p "$OUT"
[ -f "$OUT/loop/groundtruth.txt" ] ||
  "$BIN/dypho_synth" --out "$OUT/loop" --frames 600 --motion loop --people 0 --seed 2 --no-bag > /dev/null 2>&1
WEAK=(--set num_features 300 --set local_map_keyframes 0 --set local_ba_keyframes 0)
for setting in default weak; do
  for lc in true false; do
    extra=(); [ "$setting" = weak ] && extra=("${WEAK[@]}")
    line=$("$BIN/tracking_bench_sequence" --dataset "$OUT/loop" --camera "$OUT/loop/camera.yaml" \
             --set loop_closure "$lc" "${extra[@]}" | tail -1 | sed 's/ | median_ms.*//')
    echo "$setting odometry, loop_closure $lc: $line"
  done
done
