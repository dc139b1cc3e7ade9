#!/bin/bash
# The Bonn crowd frames as several overlapping windows and feature counts instead of one run.
# One run of a real crowd sequence moves by 0.2-1 cm with any small change (which frames become
# keyframes); the mean over windows x feature counts says whether a change helps beyond that.
# Each window starts at another frame, so some start with people already in view.
# Offline runner, --no-map. Prints the ATE RMSE of every run and the mean and max per setting.
#
# Usage: bench/bonn_windows.sh [--config YAML] [--features "900 1000 1100"] [--jobs N]
#                              [--shifts "0 0.033 0.066 0.1"] [--reversed] DATASET OUT
#   DATASET   a Bonn folder in TUM layout (its name must contain "bonn": the marker-to-camera
#             correction of the ground truth is chosen by the name)
#   --config  YAML passed to dypho_run_dataset (e.g. `mask: {yolo_model_path: ...}`); the
#             feature count of each setting is merged into its tracking: map
#   --windows quoted list of "FIRST:LAST" RGB line ranges (0-based, LAST excluded); default
#             "0:120 20:140 40:160 60:180 80:200" plus the whole sequence
#   --shifts  also evaluate every run with its stamps shifted by these seconds (the ground
#             truth's timing: see docs/journal/benchmarks-2026.md section 8)
#   --reversed  also the whole sequence played backwards (every stamp t of rgb.txt, depth.txt
#             and groundtruth.txt becomes first + last - t; the images are the same): real frames
#             that start with the people already in view and end in the empty room
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="${BUILD:-$ROOT/build}/devel/lib/dypho_slam"
CONFIG=""; FEATURES="900 1000 1100"; JOBS=2; SHIFTS=""; REVERSED=0
WINDOWS="0:120 20:140 40:160 60:180 80:200"
while [ $# -gt 2 ]; do
  case "$1" in
    --config) CONFIG="$2"; shift 2;;
    --features) FEATURES="$2"; shift 2;;
    --jobs) JOBS="$2"; shift 2;;
    --windows) WINDOWS="$2"; shift 2;;
    --shifts) SHIFTS="$2"; shift 2;;
    --reversed) REVERSED=1; shift;;
    *) echo "bonn_windows: unknown option $1" >&2; exit 2;;
  esac
done
if [ $# -ne 2 ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0" >&2; exit 2; fi
DATA="$(cd "$1" && pwd)"; OUT="$2"
for tool in dypho_run_dataset dypho_evaluate; do
  if [ ! -x "$BIN/$tool" ]; then echo "bonn_windows: $BIN/$tool missing: build first (scripts/build.sh)" >&2; exit 1; fi
done
for f in rgb.txt depth.txt groundtruth.txt; do
  [ -f "$DATA/$f" ] || { echo "bonn_windows: $DATA/$f missing" >&2; exit 1; }
done
case "$(basename "$DATA" | tr '[:upper:]' '[:lower:]')" in
  *bonn*) ;;
  *) echo "bonn_windows: $DATA: the folder name must contain 'bonn'" >&2; exit 1;;
esac
if [ -n "$CONFIG" ] && [ ! -f "$CONFIG" ]; then echo "bonn_windows: config $CONFIG not found" >&2; exit 1; fi
mkdir -p "$OUT/data" "$OUT/config" "$OUT/run"

# The windows: the same images (links), rgb.txt cut to the window.
datasets=("$DATA")
for w in $WINDOWS; do
  first="${w%%:*}"; last="${w##*:}"
  d="$OUT/data/rgbd_bonn_window_${first}_${last}"
  mkdir -p "$d"
  ln -sfn "$DATA/rgb" "$d/rgb"; ln -sfn "$DATA/depth" "$d/depth"
  cp "$DATA/depth.txt" "$DATA/groundtruth.txt" "$d/"
  { grep '^#' "$DATA/rgb.txt"; grep -v '^#' "$DATA/rgb.txt" | sed -n "$((first + 1)),${last}p"; } > "$d/rgb.txt"
  datasets+=("$d")
done
if [ "$REVERSED" = 1 ]; then
  d="$OUT/data/rgbd_bonn_reversed"
  mkdir -p "$d"
  ln -sfn "$DATA/rgb" "$d/rgb"; ln -sfn "$DATA/depth" "$d/depth"
  first=$(grep -v '^#' "$DATA/rgb.txt" | head -1 | awk '{print $1}')
  last=$(grep -v '^#' "$DATA/rgb.txt" | tail -1 | awk '{print $1}')
  for f in rgb.txt depth.txt groundtruth.txt; do
    { grep '^#' "$DATA/$f"
      grep -v '^#' "$DATA/$f" | awk -v s="$first" -v e="$last" '{$1 = sprintf("%.6f", s + e - $1); print}' | sort -n
    } > "$d/$f"
  done
  datasets+=("$d")
fi

# One config per feature count: the given config with tracking.num_features set.
for n in $FEATURES; do
  python3 - "$CONFIG" "$n" "$OUT/config/features_$n.yaml" <<'EOF'
import sys, yaml
path, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
cfg = (yaml.safe_load(open(path)) or {}) if path else {}
cfg.setdefault("tracking", {})["num_features"] = n
yaml.safe_dump(cfg, open(out, "w"), default_flow_style=False)
EOF
done

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "config: ${CONFIG:-defaults}; feature counts: $FEATURES; windows: $WINDOWS + whole"
runs=(); run_data=()
for n in $FEATURES; do
  for d in "${datasets[@]}"; do
    out="$OUT/run/f${n}_$(basename "$d")"
    runs+=("$out"); run_data+=("$d")
    rm -rf "$out"
    "$BIN/dypho_run_dataset" --dataset "$d" --out "$out" --quiet --no-map \
      --config "$OUT/config/features_$n.yaml" > "$out.log" 2>&1 &
    while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do sleep 0.5; done
  done
done
wait

ate() {  # ATE RMSE [cm] of trajectory $1 with its stamps shifted by $2 s, against ground truth $3
  local shifted="$1.shift"
  awk -v d="$2" '/^#/ {next} {$1 = sprintf("%.6f", $1 + d); print}' "$1" > "$shifted"
  "$BIN/dypho_evaluate" --estimate "$shifted" --groundtruth "$3" --bonn-correction |
    grep -A1 '^ATE (rigid' | tail -1 | awk '{print $2}'
  rm -f "$shifted"
}
printf "%-44s %s\n" "run" "ATE RMSE [cm] at stamp shift 0${SHIFTS:+ / $SHIFTS s}"
for i in "${!runs[@]}"; do
  out="${runs[$i]}"
  if [ ! -f "$out/trajectory.txt" ]; then printf "%-44s failed (see %s.log)\n" "$(basename "$out")" "$out"; continue; fi
  line=""
  for s in 0 $SHIFTS; do line="$line $(ate "$out/trajectory.txt" "$s" "${run_data[$i]}/groundtruth.txt")"; done
  printf "%-44s%s\n" "$(basename "$out")" "$line"
done | tee "$OUT/ate.txt"
# Mean (and max) over the runs, per stamp shift.
awk -v shifts="0 $SHIFTS" '$2 ~ /^[0-9.]+$/ {n++; for (i = 2; i <= NF; i++) {s[i] += $i; if ($i > m[i]) m[i] = $i}}
     END {k = split(shifts, sh, " "); for (i = 2; i <= k + 1 && n; i++)
            printf "shift %s s: mean ATE RMSE over %d runs %.2f cm (max %.2f cm)\n", sh[i - 1], n, s[i] / n, m[i]}' "$OUT/ate.txt"
