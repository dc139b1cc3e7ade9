#!/bin/bash
# Runs the reference measurements on this machine and records one row per run in
# docs/results/rows.tsv (a row with the same dataset, mode and mask on the same machine is
# replaced), then regenerates docs/results.md and the README's results table from that file
# (scripts/results_table.py). Numbers are never typed by hand: they come from these runs.
#
# Usage: bench/results.sh [--only NAME[,NAME...]] [--repeats N] [--list] [--no-table]
#   NAME: a run below (synthetic, fr1_flow, fr1_none, bonn_flow, bonn_detector, and the same with
#         _live for dypho_run_dataset --realtime at 1x, and _graph for the ROS graph at 1x; the
#         graph always masks, so there is no fr1_none_graph).
#   --repeats: runs of each live mode (not repeatable; default 3): the row has the median and the
#   ATE's range. Offline runs are deterministic: one each.
#   Build first: bash scripts/build.sh. ../shared must sit beside the repository for the real
#   sequences (runs whose data is missing are listed as not run, never recorded).
#   DYPHO_BUILD_DIR (default build/), DYPHO_DEVEL (the devel space; default $DYPHO_BUILD_DIR/devel,
#   ~/catkin_ws/devel after catkin_make), DYPHO_SHARED_DIR (default ../shared), OUT (the runs'
#   output folders; default /tmp/dypho_results).
set -euo pipefail
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0; fi
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${DYPHO_BUILD_DIR:-$ROOT/build}"
SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
OUT="${OUT:-/tmp/dypho_results}"
DEVEL="${DYPHO_DEVEL:-$BUILD/devel}"
BIN="$DEVEL/lib/dypho_slam"
ROWS="$ROOT/docs/results/rows.tsv"
only="" list=0 table=1 REPEATS=3
while [ $# -gt 0 ]; do
  case "$1" in
    --only) only=",$2,"; shift 2 ;;
    --list) list=1; shift ;;
    --no-table) table=0; shift ;;
    --repeats) REPEATS="$2"; shift 2 ;;
    *) echo "results.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done

FR1="$SHARED/data/tum_fr1_rpy_first150"
BONN="$SHARED/data/rgbd_bonn_crowd_frames200to399"
MODEL="$SHARED/models/yolox_nano.onnx"
SYNTH="$OUT/synthetic_seed1"
# name | dataset label | data folder | mask | extra arguments of dypho_run_dataset
RUNS=(
  "synthetic|synthetic room, 2 people (dypho_synth seed 1, 300 frames)|$SYNTH|flow|"
  "fr1_flow|TUM fr1/rpy, first 150 frames|$FR1|flow|"
  "fr1_none|TUM fr1/rpy, first 150 frames|$FR1|none|"
  "bonn_flow|Bonn crowd, frames 200-399|$BONN|flow|"
  "bonn_detector|Bonn crowd, frames 200-399|$BONN|detector|"
)
if [ "$list" = 1 ]; then
  for r in "${RUNS[@]}"; do n="${r%%|*}"; [ "$n" = fr1_none ] && echo "$n ${n}_live" || echo "$n ${n}_live ${n}_graph"; done; exit 0
fi

machine="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
commit="$(git -C "$ROOT" rev-parse --short=10 HEAD)"
# Uncommitted changes to what is measured (code, parameters, launch files, these scripts) make the
# commit column a lie: say so in the row.
if ! git -C "$ROOT" diff --quiet HEAD -- CMakeLists.txt package.xml cmake config launch bench tools \
       dypho_common dypho_mask dypho_tracking dypho_mapping dypho_pipeline dypho_msgs; then
  commit="$commit+changes"
fi
mkdir -p "$OUT" "$(dirname "$ROWS")"
[ -f "$ROWS" ] || printf 'date\tdataset\tframes\tmode\tmask\truns\tate_cm\tate_range_cm\tpsnr_db\tview_psnr_db\tcoverage_pct\tms_per_frame\tposed\tmachine\tcommit\tcommand\n' > "$ROWS"

# record NAME DATASET MODE MASK COMMAND RUNS_FILE: one row from the runs in RUNS_FILE (one line per
# run: frames, ATE cm, keyframe PSNR dB, ms/frame, frames posed, PSNR dB and coverage % at every
# 10th frame; '-' where a run has none), replacing the
# row of the same dataset, mode and mask measured on the same machine. Several runs (the live
# modes are not repeatable) give the median and the ATE's range.
record() {
  /usr/bin/python3 - "$ROWS" "$(date -u +%Y-%m-%d)" "$2" "$3" "$4" "$5" "$6" "$machine" "$commit" <<'PY'
import os, statistics, sys
path, date, dataset, mode, mask, command, runs_file, machine, commit = sys.argv[1:]
runs = [l.split() for l in open(runs_file) if l.strip()]
def column(i):
    return [float(r[i]) for r in runs if r[i] != "-"]
def median(i, fmt):
    v = column(i)
    return fmt % statistics.median(v) if v else "-"
ate = column(1)
frames = runs[0][0]
row = [date, dataset, frames, mode, mask, str(len(runs)), median(1, "%.2f"),
       "%.2f-%.2f" % (min(ate), max(ate)) if len(ate) > 1 else "-", median(2, "%.2f"), median(5, "%.2f"),
       median(6, "%.1f"), median(3, "%.1f"), median(4, "%.0f") + " of " + frames, machine, commit, command]
with open(path) as f:
    lines = f.read().splitlines()
header, body = lines[0], [l.split("\t") for l in lines[1:] if l.strip()]
key = lambda r: (r[1], r[3], r[4], r[13])  # dataset, mode, mask, machine
body = [r for r in body if key(r) != key(row)] + [row]
with open(path + ".tmp", "w") as f:
    f.write(header + "\n" + "".join("\t".join(r) + "\n" for r in body))
os.replace(path + ".tmp", path)
print("results.sh: recorded %s, %s, %s: %s run(s), ATE %s cm (%s), PSNR %s dB at every 10th frame "
      "(coverage %s %%; keyframes %s dB), posed %s" % (dataset, mode, mask, row[5], row[6], row[7], row[9], row[10],
                                                       row[8], row[12]))
PY
}

# field TEXT PATTERN: the first number after PATTERN in TEXT, or '-'.
field() { printf '%s\n' "$1" | grep -m1 -oP "$2"'\s*\K[0-9.]+' || echo "-"; }

offline() {  # name label data mask: dypho_run_dataset, deterministic (LIVE=0) or at 1x (LIVE=1)
  local name="$1" label="$2" data="$3" mask="$4"
  local mask_args=(--mask "$mask") cfg=()
  if [ "$mask" = "detector" ]; then
    printf 'mask:\n  yolo_model_path: "%s"\n' "$MODEL" > "$OUT/detector.yaml"
    mask_args=(--mask flow --config "$OUT/detector.yaml"); cfg=(--config detector.yaml)
  fi
  local mode="offline" rt=() n=1
  [ "${LIVE:-0}" = 1 ] && { mode="runner 1x"; rt=(--realtime); name="${name}_live"; n="$REPEATS"; }
  : > "$OUT/$name.runs"
  for ((k = 1; k <= n; ++k)); do
    echo "results.sh: $name, run $k of $n"
    local text frames posed
    text="$("$BIN/dypho_run_dataset" --dataset "$data" --out "$OUT/$name" --quiet "${mask_args[@]}" "${rt[@]}")"
    printf '%s\n' "$text" > "$OUT/$name.$k.txt"
    frames="$(printf '%s\n' "$text" | grep -m1 -oP '^frames:\s*[0-9]+ of \K[0-9]+')"
    posed="$(field "$text" '^posed:')"; [ "$posed" != "-" ] || posed="$(field "$text" '^frames:')"
    echo "$frames $(field "$text" '^ATE RMSE:') $(field "$text" '^map PSNR:') $(field "$text" '^time:') $posed" \
      "$(field "$text" '^map views:\s*all\s*[0-9]+ views: PSNR') $(field "$text" '^map views:.*coverage')" >> "$OUT/$name.runs"
  done
  local shown_mask="${mask_args[*]}"
  record "$name" "$label" "$mode" "$mask" \
    "dypho_run_dataset --dataset $(basename "$data") ${rt[*]} --mask ${shown_mask#--mask } ${cfg[*]}" "$OUT/$name.runs"
}

graph() {  # name label data mask: the bag through tum_bag.launch at rate 1.0
  local name="${1}_graph" label="$2" data="$3" mask="$4"
  [ "$mask" = "none" ] && { echo "results.sh: $name: the graph always masks; not run"; return; }
  # shellcheck disable=SC1091
  set +u; source "$DEVEL/setup.bash"; set -u
  local bag="$OUT/$(basename "$data").bag" det=() extra=()
  [ -f "$bag" ] || "$BIN/dypho_dataset_to_bag" --dataset "$data" --out "$bag" > /dev/null
  [ "$mask" = "detector" ] && det=(--detector "$MODEL")
  [ "$data" = "$BONN" ] && extra=(--bonn-correction)
  # tum_bag.launch models the TUM and Bonn cameras' rolling shutter (30 ms, as their camera files
  # say for the runner); the generator's camera has a global shutter.
  local readout=()
  [ "$data" = "$SYNTH" ] && readout=(--launch-arg rolling_shutter_readout_ms:=0)
  extra+=("${readout[@]}")
  : > "$OUT/$name.runs"
  for ((k = 1; k <= REPEATS; ++k)); do
    echo "results.sh: $name, run $k of $REPEATS"
    DYPHO_BIN="$BIN" bash "$ROOT/bench/realtime_graph.sh" "$bag" --out "$OUT/$name.$k" "${det[@]}" \
      --groundtruth "$data/groundtruth.txt" "${extra[@]}" > "$OUT/$name.$k.log" 2>&1 || true
    local s; s="$(cat "$OUT/$name.$k/summary.txt" 2>/dev/null || true)"
    echo "$(field "$s" '^frames in:') $(field "$s" '^ATE:\s*rmse') $(field "$s" '^map PSNR:') - $(field "$s" '^statuses:')" \
      "$(field "$s" '^map views:\s*all\s*[0-9]+ views: PSNR') $(field "$s" '^map views:.*coverage')" >> "$OUT/$name.runs"
  done
  record "$name" "$label" "graph 1x" "$mask" \
    "bench/realtime_graph.sh $(basename "$bag") ${det[*]:+--detector yolox_nano.onnx} ${readout[*]}" "$OUT/$name.runs"
}

[ -x "$BIN/dypho_run_dataset" ] || { echo "results.sh: build first (bash scripts/build.sh): no $BIN/dypho_run_dataset" >&2; exit 1; }
if { [ -z "$only" ] || [[ "$only" == *_graph,* ]]; } && [ ! -x "$BIN/graph_soak_probe" ]; then
  echo "results.sh: the graph runs need the benchmark programs: bash scripts/build.sh (or catkin_make benches)" >&2; exit 1
fi
[ -d "$SYNTH" ] || "$BIN/dypho_synth" --out "$SYNTH" --frames 300 --motion halfsphere --people 2 --seed 1 --no-bag > /dev/null
for r in "${RUNS[@]}"; do
  IFS='|' read -r name label data mask extra <<< "$r"
  for variant in "" _live _graph; do
    [ -z "$only" ] || [[ "$only" == *",$name$variant,"* ]] || continue
    if [ ! -d "$data" ] || { [ "$mask" = "detector" ] && [ ! -f "$MODEL" ]; }; then
      echo "results.sh: $name$variant not run: $data or the model is missing"; continue
    fi
    case "$variant" in
      "") LIVE=0 offline "$name" "$label" "$data" "$mask" ;;
      _live) LIVE=1 offline "$name" "$label" "$data" "$mask" ;;
      _graph) graph "$name" "$label" "$data" "$mask" ;;
    esac
  done
done
[ "$table" = 0 ] || /usr/bin/python3 "$ROOT/scripts/results_table.py"
