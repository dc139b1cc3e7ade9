#!/bin/bash
# Ablation on the Bonn crowd frames (paper's table): dynamic mask none / flow / detector + flow,
# each with: "relaxed" = FAST threshold relaxation under the mask + the paper's relaxed feature
# test (the defaults), "adaptive" = FAST threshold relaxation only, "fixed" = neither. Prints the final-trajectory ATE
# (and the online one) of `dypho_run_dataset` per case.
# Usage: bench/tracking_ablation.sh [BUILD_DIR] [OUT_DIR]   (../shared must sit beside the repo)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-/tmp/dypho_ablation}"
BIN="$BUILD/devel/lib/dypho_slam"
SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
DATA="$SHARED/data/rgbd_bonn_crowd_frames200to399"
MODEL="$SHARED/models/yolox_nano.onnx"
mkdir -p "$OUT"

config() {  # $1 = file, $2 = detector (yes/no), $3 = features (adaptive/fixed/relaxed)
  {
    if [ "$2" = yes ]; then printf 'mask:\n  yolo_model_path: "%s"\n' "$MODEL"; fi
    printf 'tracking:\n'
    case "$3" in
      adaptive) printf '  relaxed_features: false\n' ;;
      fixed) printf '  relaxed_features: false\n  mask_threshold_relaxation: 0.0\n' ;;
      relaxed) printf '  relaxed_features: true\n' ;;
    esac
  } > "$1"
}

run() {  # $1 = name, $2 = --mask value, $3 = detector, $4 = features
  config "$OUT/$1.yaml" "$3" "$4"
  local line
  line=$("$BIN/dypho_run_dataset" --dataset "$DATA" --out "$OUT/$1" --quiet --mask "$2" \
           --config "$OUT/$1.yaml" | grep -E "^ATE" | tr '\n' ' ')
  echo "$1: $line"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg)"
run none none no adaptive
for det in no yes; do
  name=flow; [ "$det" = yes ] && name=detector_flow
  for features in adaptive fixed relaxed; do
    run "${name}_${features}" flow "$det" "$features"
  done
done
