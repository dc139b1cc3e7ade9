#!/bin/bash
# A live graph that falls behind drops frames; whether tracking bridges the gap depends on how
# they are spread. One sequence, offline (--no-map, deterministic), on nineteen inputs:
#   whole;
#   burst at p    ten consecutive frames removed, starting at p % of the sequence (p = 10..90);
#   thinned at p  ten frames removed every other one around the same place (the frames
#                 start-9, start-7, ..., start+9), as the tracking nodelet's queue drops them now
#                 (mask_pairing.h).
# Prints each input's ATE RMSE [cm] (final trajectory) and "not tracked" count, then the mean of
# each group (docs/journal/benchmarks-2026.md, section 29).
#
# Usage: bench/burst_removal.sh [--config YAML] [--mask flow|none|gt] DATASET OUT
#   DATASET   a folder in TUM layout with groundtruth.txt (a Bonn folder's name must contain
#             "bonn", a TUM one "freiburgN", as the runner detects the camera from the name)
# OUT gets inputs/, runs/<input>/ and ate.txt. BUILD: the catkin build folder (default build/).
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
    *) echo "burst_removal: unknown option $1" >&2; exit 2;;
  esac
done
if [ $# -ne 2 ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0" >&2; exit 2; fi
DATA="$(cd "$1" && pwd)"; OUT="$2"
[ -x "$BIN/dypho_run_dataset" ] || { echo "burst_removal: $BIN/dypho_run_dataset missing: build first" >&2; exit 1; }
[ -f "$DATA/groundtruth.txt" ] || { echo "burst_removal: $DATA/groundtruth.txt missing" >&2; exit 1; }
if [ -n "$CONFIG" ] && [ ! -f "$CONFIG" ]; then echo "burst_removal: config $CONFIG not found" >&2; exit 1; fi
name="$(basename "$DATA")"
frames=$(grep -vc '^#' "$DATA/rgb.txt")
args=(--quiet --no-map --mask "$MASK")
[ -n "$CONFIG" ] && args+=(--config "$CONFIG")
mkdir -p "$OUT/inputs" "$OUT/runs"
run() {  # run INPUT_NAME DATASET_DIR -> "name ate not_tracked"
  local out="$OUT/runs/$1"
  rm -rf "$out"
  "$BIN/dypho_run_dataset" --dataset "$2" --out "$out" "${args[@]}" > "$out.log" 2>&1 ||
    { echo "burst_removal: the run $1 failed (see $out.log)" >&2; exit 1; }
  local ate nt
  ate=$(grep -m1 '^ATE RMSE' "$out/evaluation.txt" | awk '{print $3}')
  nt=$(grep -o '[0-9]* not tracked' "$out.log" | awk '{print $1}')
  printf "%-12s %6s cm  %3s not tracked\n" "$1" "$ate" "${nt:-0}"
}
{
  echo "# $name ($frames frames), mask $MASK, config ${CONFIG:-defaults}, $(nproc) cores"
  run whole "$DATA"
  for p in 10 20 30 40 50 60 70 80 90; do
    start=$((frames * p / 100))
    if [ $((start - 9)) -lt 1 ] || [ $((start + 9)) -ge "$frames" ]; then continue; fi  # too short
    burst=$(seq -s, "$start" $((start + 9)))
    thinned=$(seq -s, $((start - 9)) 2 $((start + 9)))
    for kind in burst thinned; do
      list=$burst; [ "$kind" = thinned ] && list=$thinned
      d="$OUT/inputs/${name}_${kind}$p"
      bash "$ROOT/bench/drop_frames.sh" "$DATA" "$d" frames "$list" > /dev/null
      run "${kind}_$p" "$d"
    done
  done
} | tee "$OUT/ate.txt"
awk '/^burst/ {b += $2; nb++} /^thinned/ {t += $2; nt++} /^whole/ {w = $2}
     END {printf "mean: whole %.2f, burst %.2f, thinned %.2f cm\n", w, b / nb, t / nt}' "$OUT/ate.txt" | tee -a "$OUT/ate.txt"
