#!/usr/bin/env bash
# realtime_runner.sh OUT [DATASET...]
#
# Runs dypho_run_dataset on each DATASET (default: the shared Bonn crowd frames 200-399 and TUM
# fr1/rpy first 150 from ../shared/data) with the flow mask and with the YOLOX-nano detector
# (../shared/models/yolox_nano.onnx), each in the default deterministic mode and with --realtime,
# and prints one markdown table row per run: ms/frame median, frames posed of the sequence,
# dropped, latency p50/p95 (realtime only), ATE, and the CPU the machine's other processes used
# during the run, in cores (busy time from /proc/stat minus the run's own user+system time, over
# its wall time; 0.0 = quiet, 2.0 = both cores taken by others).
# The runs' outputs stay in OUT/<dataset>_<mask>_<mode>/ (log.txt is the runner's summary).
# DYPHO_BIN: folder of dypho_run_dataset (default build/devel/lib/dypho_slam).
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="${DYPHO_BIN:-$ROOT/build/devel/lib/dypho_slam}"
SHARED="$ROOT/../shared"
[[ $# -ge 1 ]] || { sed -n '2p' "$0" | sed 's/^# //' >&2; exit 2; }
out="$(realpath -m "$1")"; shift
datasets=("$@")
[[ ${#datasets[@]} -gt 0 ]] || datasets=("$SHARED/data/rgbd_bonn_crowd_frames200to399" "$SHARED/data/tum_fr1_rpy_first150")
model="$SHARED/models/yolox_nano.onnx"
[[ -f "$model" ]] || { echo "realtime_runner.sh: no detector model at $model" >&2; exit 2; }
[[ -x "$BIN/dypho_run_dataset" ]] || { echo "realtime_runner.sh: build dypho_run_dataset first ($BIN)" >&2; exit 2; }
mkdir -p "$out"
printf 'mask:\n  yolo_model_path: "%s"\n' "$model" > "$out/detector.yaml"

busy_s() {  # CPU busy seconds of the whole machine since boot (user nice system irq softirq steal)
  awk -v hz="$(getconf CLK_TCK)" '/^cpu / { print ($2 + $3 + $4 + $7 + $8 + $9) / hz }' /proc/stat
}
echo "| sequence | mask | mode | ms/frame median | posed / frames | dropped | latency p50 / p95 | ATE | others' CPU [cores] |"
echo "|---|---|---|---|---|---|---|---|---|"
for dataset in "${datasets[@]}"; do
  [[ -d "$dataset" ]] || { echo "realtime_runner.sh: no dataset folder $dataset" >&2; exit 2; }
  name="$(basename "$dataset")"
  frames=$(grep -vc '^#' "$dataset/rgb.txt")
  for mask in flow detector; do
    config=()
    [[ $mask == detector ]] && config=(--config "$out/detector.yaml")
    for mode in default realtime; do
      extra=()
      [[ $mode == realtime ]] && extra=(--realtime)
      dir="$out/${name}_${mask}_${mode}"
      busy0="$(busy_s)"
      /usr/bin/time -f "%e %U %S" -o "$dir.cpu" \
        "$BIN/dypho_run_dataset" --dataset "$dataset" --out "$dir" --quiet "${config[@]}" "${extra[@]}" > "$dir.log" 2>&1 \
        || { echo "realtime_runner.sh: run failed, see $dir.log" >&2; exit 1; }
      busy1="$(busy_s)"
      others=$(awk -v b0="$busy0" -v b1="$busy1" '{ printf "%.2f", (b1 - b0 - $2 - $3) / $1 }' "$dir.cpu")
      mv "$dir.log" "$dir/log.txt"; mv "$dir.cpu" "$dir/cpu.txt"
      ms=$(sed -n 's/^time: *\([0-9.]*\) ms.*/\1/p' "$dir/log.txt")
      posed=$(grep -vc '^#' "$dir/trajectory.txt" || true)
      ate=$(sed -n 's/^ATE RMSE: *\([0-9.]*\) cm.*/\1 cm/p' "$dir/log.txt")
      dropped=0 latency="-"
      if [[ $mode == realtime ]]; then
        dropped=$(sed -n 's/.* \([0-9]*\) dropped, no pose.*/\1/p' "$dir/log.txt")
        latency=$(sed -n 's/^latency: *\([0-9.]*\) ms p50, \([0-9.]*\) ms p95.*/\1 \/ \2 ms/p' "$dir/log.txt")
      fi
      echo "| $name | $mask | $mode | $ms | $posed / $frames | $dropped | $latency | $ate | $others |"
    done
  done
done
