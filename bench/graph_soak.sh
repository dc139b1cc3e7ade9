#!/usr/bin/env bash
# graph_soak.sh [FRAMES] [OUT]: the graph soak. A synthetic sequence of FRAMES frames (default
# 3000; 2 people, halfsphere camera) is written as a bag and played through
# `roslaunch dypho_slam tum_bag.launch` at rate 1.0; graph_soak_probe records resident memory of
# the nodelet manager, Gaussian count, keyframes and status latency every 100 frames into
# OUT/graph_soak.csv, plotted to OUT/graph_soak.png. Prints frames in, statuses and poses out.
# Needs the catkin build (scripts/build.sh) and its environment (source build/devel/setup.bash).
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/bench/graph_launch.sh"
BIN="${DYPHO_BIN:-$ROOT/build/devel/lib/dypho_slam}"
frames="${1:-3000}"
out="$(realpath -m "${2:-graph_soak}")"
mkdir -p "$out"
if [[ ! -f "$out/synth/synthetic.bag" ]]; then
  "$BIN/dypho_synth" --out "$out/synth" --frames "$frames" --motion halfsphere --people 2 --seed 9 > "$out/synth.log"
fi
rm -rf "$out/run"
start_graph "$out" bag:="$out/synth/synthetic.bag" output_dir:="$out/run" start_delay:=8.0 \
  rolling_shutter_readout_ms:=0   # the generator's global shutter
"$BIN/graph_soak_probe" --pid "$manager_pid" --out "$out/graph_soak.csv" --expect "$frames" --every 100
wait "$launch_pid" || true
"$BIN/soak_runner" --plot-csv "$out/graph_soak.csv" --plot "$out/graph_soak.png"
poses=$(grep -vc '^#' "$out/run/trajectory.txt" || true)
echo "graph soak: $frames frames in, $(($(wc -l < "$out/graph_soak.csv") - 1)) rows, $poses poses in trajectory.txt"
if [[ -x "$BIN/dypho_evaluate" ]]; then
  "$BIN/dypho_evaluate" --groundtruth "$out/synth/groundtruth.txt" --estimate "$out/run/trajectory.txt" 2>&1 | tail -3 || true
fi
