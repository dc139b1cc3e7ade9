#!/bin/bash
# A missing frame must cost nothing (issue 34): one sequence on fifteen inputs, the whole
# sequence and fourteen with frames removed from rgb.txt (bench/drop_frames.sh), each through the
# offline runner (--no-map, deterministic). The inputs:
#   whole;
#   e15 o=0,3,6,9,12   every 15th frame removed, at five offsets (as a loaded live graph drops);
#   r10 s=1..5         10 % removed at random, five seeds;
#   skip 30,60,90      one frame removed: the 30th, the 60th or the 90th;
#   f20_40             frames 20 and 40 (counted from 0) removed: two unreadable frames early on.
# Prints each input's ATE RMSE [cm] (final trajectory), then the means of the groups and the mean,
# median and range of all fifteen (docs/journal/benchmarks-2026.md, section 15).
#
# Usage: bench/frame_removal.sh [--config YAML] [--mask flow|none|gt] [--late-mask-poses] DATASET OUT
#   DATASET   a folder in TUM layout with groundtruth.txt (a Bonn folder's name must contain
#             "bonn", as the runner detects the camera and the ground-truth correction from it)
#   --config  YAML passed to dypho_run_dataset (e.g. `mask: {yolo_model_path: ...}`)
#   --mask    passed to dypho_run_dataset (default flow)
#   --late-mask-poses  passed to dypho_run_dataset: the mask gets each pose one frame late, as
#             the live graph's mask does whenever tracking is slower than its wait (repeatable)
# OUT gets inputs/ (the variants, images linked), runs/<input>/ and ate.txt.
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="${BUILD:-$ROOT/build}/devel/lib/dypho_slam"
CONFIG=""; MASK="flow"; LATE=""
while [ $# -gt 2 ]; do
  case "$1" in
    --late-mask-poses) LATE="--late-mask-poses"; shift;;
    --config) CONFIG="$(cd "$(dirname "$2")" && pwd)/$(basename "$2")"; shift 2;;
    --mask) MASK="$2"; shift 2;;
    *) echo "frame_removal: unknown option $1" >&2; exit 2;;
  esac
done
if [ $# -ne 2 ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0" >&2; exit 2; fi
DATA="$(cd "$1" && pwd)"; OUT="$2"
NAME="$(basename "$DATA")"
mkdir -p "$OUT/inputs" "$OUT/runs"
OUT="$(cd "$OUT" && pwd)"
drop() { bash "$ROOT/bench/drop_frames.sh" "$DATA" "$OUT/inputs/${NAME}_$1" "${@:2}" > /dev/null; }
INPUTS=("$DATA")
for o in 0 3 6 9 12; do drop "e15o$o" every 15 "$o"; INPUTS+=("$OUT/inputs/${NAME}_e15o$o"); done
for s in 1 2 3 4 5; do drop "r10s$s" random 0.1 "$s"; INPUTS+=("$OUT/inputs/${NAME}_r10s$s"); done
for k in 30 60 90; do drop "skip$k" frames "$((k - 1))"; INPUTS+=("$OUT/inputs/${NAME}_skip$k"); done
drop "f20_40" frames 20,40; INPUTS+=("$OUT/inputs/${NAME}_f20_40")
: > "$OUT/ate.txt"
for input in "${INPUTS[@]}"; do
  label="$(basename "$input")"; label="${label#"$NAME"}"; label="${label#_}"; label="${label:-whole}"
  args=(--dataset "$input" --out "$OUT/runs/$label" --quiet --no-map --mask "$MASK")
  [ -n "$CONFIG" ] && args+=(--config "$CONFIG")
  [ -n "$LATE" ] && args+=("$LATE")
  ate="$("$BIN/dypho_run_dataset" "${args[@]}" 2> "$OUT/runs/$label.log" | awk '/^ATE RMSE/ {print $3; exit}')"
  if [ -z "$ate" ]; then echo "frame_removal: no ATE for $label (see $OUT/runs/$label.log)" >&2; exit 1; fi
  echo "$label $ate" | tee -a "$OUT/ate.txt"
done
sort -k2 -g "$OUT/ate.txt" | awk '
  {v[NR] = $2; sum += $2; g = $1; sub(/(o|s)[0-9]+$/, "", g); sub(/^skip[0-9]+$/, "skip", g); gs[g] += $2; gn[g]++}
  END {
    printf "groups:"; for (g in gs) printf " %s %.2f", g, gs[g] / gn[g]; printf "\n"
    printf "all %d: mean %.2f, median %.2f, range %.2f-%.2f cm\n", NR, sum / NR, v[int((NR + 1) / 2)], v[1], v[NR]
  }'
