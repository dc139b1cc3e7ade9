#!/usr/bin/env bash
# graph_ab.sh [--pairs N] CONFIG_DIR_A CONFIG_DIR_B OUT BAG [realtime_graph.sh options ...]
#
# Compares two parameter folders through the live graph at 1x, where one run says little: the
# same bag gives 0.6-1.1 cm on fr1/rpy from run to run (how many frames queue behind a keyframe
# decides how old the mask's predictions get). Plays BAG through bench/realtime_graph.sh N times
# with each folder (default 10 pairs), the two alternated run by run and the order swapped every
# other pair (A B, B A, ...), so that a slower or faster phase of the machine falls on both.
# The options after BAG go to every run (e.g. --no-map-views --groundtruth GT --bonn-correction
# --detector MODEL.onnx); --config-dir is set per side.
# Writes OUT/runs/{a,b}_K/ (each run's realtime_graph.sh output) and OUT/runs.txt (one line per
# run: side, pair, ATE RMSE [cm], frames answered, frames in, frames in catch-up mode) and prints
# per side: runs, ATE mean, median and range [cm], the fewest frames answered, and the mean
# number of frames tracked in catch-up mode.
# Needs the catkin build and its environment (source build/devel/setup.bash), as realtime_graph.sh.
help() { awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; }
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then help; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
pairs=10
if [[ "${1:-}" == "--pairs" ]]; then pairs="$2"; shift 2; fi
if [[ $# -lt 4 ]] || ! [[ "$pairs" =~ ^[1-9][0-9]*$ ]]; then help >&2; exit 2; fi
dir_a="$(realpath "$1")" dir_b="$(realpath "$2")" out="$3" bag="$(realpath "$4")"
shift 4
for d in "$dir_a" "$dir_b"; do
  [[ -f "$d/tracking.yaml" ]] || { echo "graph_ab.sh: $d is not a parameter folder (no tracking.yaml)" >&2; exit 2; }
done
[[ -f "$bag" ]] || { echo "graph_ab.sh: no bag at $bag" >&2; exit 2; }
mkdir -p "$out/runs"
out="$(realpath "$out")"
: > "$out/runs.txt"

# run SIDE PAIR DIR: one realtime_graph.sh run; appends its line to runs.txt.
run() {
  local side="$1" pair="$2" dir="$3" run_out="$out/runs/${1}_$2"
  if ! bash "$ROOT/bench/realtime_graph.sh" "$bag" --config-dir "$dir" --out "$run_out" "${options[@]}" \
      > "$run_out.log" 2>&1; then
    echo "graph_ab.sh: run $side $pair failed (see $run_out.log)" >&2
    exit 1
  fi
  local summary="$run_out/summary.txt"
  local ate answered frames_in caught_up
  ate="$(awk '/^ATE:/ {print $3; exit}' "$summary")"
  answered="$(awk '/^statuses:/ {print $2; exit}' "$summary")"
  frames_in="$(awk '/^frames in:/ {print $3; exit}' "$summary")"
  caught_up="$(sed -n 's/^tracking:.* \([0-9]*\) caught up.*/\1/p' "$summary" | head -1)"
  if [[ -z "$ate" || -z "$answered" ]]; then
    echo "graph_ab.sh: no ATE in $summary (pass --groundtruth, or put groundtruth.txt beside the bag)" >&2
    exit 1
  fi
  echo "$side $pair $ate $answered $frames_in ${caught_up:--}" | tee -a "$out/runs.txt"
}

options=("$@")
for o in "${options[@]}"; do
  [[ "$o" == --config-dir || "$o" == --out ]] && { echo "graph_ab.sh: $o is set per run" >&2; exit 2; }
done
for ((k = 1; k <= pairs; ++k)); do
  if ((k % 2)); then
    run a "$k" "$dir_a"; run b "$k" "$dir_b"
  else
    run b "$k" "$dir_b"; run a "$k" "$dir_a"
  fi
done

echo "A = $dir_a"
echo "B = $dir_b"
for side in a b; do
  awk -v side="$side" '$1 == side' "$out/runs.txt" | sort -k3 -g | awk -v side="${side^^}" '
    {v[NR] = $3; sum += $3; if (min == "" || $4 < min) min = $4; frames = $5; if ($6 != "-") {cu += $6; ncu++}}
    END {
      median = NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2
      printf "%s: %d runs, ATE mean %.2f, median %.2f, range %.2f-%.2f cm; fewest answered %d of %d; catch-up %s frames per run\n",
             side, NR, sum / NR, median, v[1], v[NR], min, frames, ncu ? sprintf("%.1f", cu / ncu) : "-"
    }'
done
