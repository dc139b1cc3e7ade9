#!/bin/bash
# A longer sequence from a short one: the frames played forwards and then backwards, so that the
# camera comes back to where it started (twice the frames; the same images). The shared TUM and
# Bonn frames are 150-200 frames long; full-length sequences are 4-6 times that and sweep back
# and forth over the same scene. This shows what a return over a mapped scene does (local map,
# keyframes, loop closure), which a single pass cannot. Played backwards, a rolling shutter's
# rows run against time, which the tracker's rolling-shutter model (on for the TUM and Bonn
# cameras) cannot describe, and the backward half loses for that reason alone. To judge
# a return, turn the model off for both runs (--config with
# `tracking: {rolling_shutter_readout_ms: 0}`); docs/journal/2026-12-05-gaps-and-async-local-ba.md.
# Offline runner, --no-map. Prints the ATE RMSE of the forward-only and the ping-pong run.
#
# Usage: bench/pingpong.sh [--config YAML] [--mask flow|none] DATASET OUT
#   DATASET   a folder in TUM layout with groundtruth.txt. The camera is detected from its name
#             or headers as by dypho_run_dataset; the copy keeps both ("<name>_pingpong").
#   --config  YAML passed to dypho_run_dataset (e.g. `mask: {yolo_model_path: ...}`)
#   --mask    passed to dypho_run_dataset (default flow)
# The backward half: a line with stamp t (first <= t <= last, the RGB stamps) is repeated at
# 2 last + dt - t, dt = 1/30 s, for rgb.txt, depth.txt and groundtruth.txt alike.
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="${BUILD:-$ROOT/build}/devel/lib/dypho_slam"
CONFIG=""; MASK="flow"
while [ $# -gt 2 ]; do
  case "$1" in
    --config) CONFIG="$2"; shift 2;;
    --mask) MASK="$2"; shift 2;;
    *) echo "pingpong: unknown option $1" >&2; exit 2;;
  esac
done
if [ $# -ne 2 ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0" >&2; exit 2; fi
DATA="$(cd "$1" && pwd)"; OUT="$2"
[ -x "$BIN/dypho_run_dataset" ] || { echo "pingpong: $BIN/dypho_run_dataset missing: build first (scripts/build.sh)" >&2; exit 1; }
for f in rgb.txt depth.txt groundtruth.txt; do
  [ -f "$DATA/$f" ] || { echo "pingpong: $DATA/$f missing" >&2; exit 1; }
done
if [ -n "$CONFIG" ] && [ ! -f "$CONFIG" ]; then echo "pingpong: config $CONFIG not found" >&2; exit 1; fi

d="$OUT/data/$(basename "$DATA")_pingpong"
mkdir -p "$d"
ln -sfn "$DATA/rgb" "$d/rgb"; ln -sfn "$DATA/depth" "$d/depth"
first=$(grep -v '^#' "$DATA/rgb.txt" | head -1 | awk '{print $1}')
last=$(grep -v '^#' "$DATA/rgb.txt" | tail -1 | awk '{print $1}')
for f in rgb.txt depth.txt groundtruth.txt; do
  { grep '^#' "$DATA/$f" || true
    # Forward lines up to the turn, then the mirrored ones after it (each stamp appears once).
    grep -v '^#' "$DATA/$f" | awk -v s="$first" -v e="$last" '
      NF == 0 {next}
      { dt = 1.0 / 30.0; turn = 2 * e + dt; t = $1
        if (t <= e + dt / 2) print
        m = turn - t
        if (m > e + dt / 2 && t >= s - 0.5) { $1 = sprintf("%.6f", m); print } }' | sort -n -k1,1
  } > "$d/$f"
done

args=(--quiet --no-map --mask "$MASK")
[ -n "$CONFIG" ] && args+=(--config "$CONFIG")
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "dataset: $DATA ($(grep -vc '^#' "$DATA/rgb.txt") frames; ping-pong $(grep -vc '^#' "$d/rgb.txt")); config: ${CONFIG:-defaults}; mask: $MASK"
for run in forward pingpong; do
  src="$DATA"; [ "$run" = pingpong ] && src="$d"
  rm -rf "$OUT/$run"
  "$BIN/dypho_run_dataset" --dataset "$src" --out "$OUT/$run" "${args[@]}" > "$OUT/$run.log" 2>&1 ||
    { echo "pingpong: the $run run failed (see $OUT/$run.log)" >&2; exit 1; }
  printf "%-9s %s\n" "$run" "$(grep -m1 '^ATE RMSE' "$OUT/$run/evaluation.txt")"
done | tee "$OUT/ate.txt"
