#!/bin/bash
# The deterministic outputs of dypho_run_dataset on the shared sequences and a synthetic one, as
# SHA-256 sums: a restructuring that must not change behaviour is checked by running this on the
# build before and after and comparing the two lists (`diff`). Every file compared is written by
# the default (deterministic) mode: trajectories, keyframes, the masks tracking used, the
# Gaussian map and the point cloud. Timing files and the renders' PNG metadata are left out.
# Usage: bench/output_fingerprint.sh [BUILD_DIR] [OUT_DIR]   (prints the list; ../shared beside the repo)
#   DYPHO_FINGERPRINT_RUNS: which runs (default: all of synthetic fr1_flow fr1_none bonn_flow bonn_detector)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-/tmp/dypho_fingerprint}"
BIN="$BUILD/devel/lib/dypho_slam"
SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
RUNS="${DYPHO_FINGERPRINT_RUNS:-synthetic fr1_flow fr1_none bonn_flow bonn_detector}"
FR1="$SHARED/data/tum_fr1_rpy_first150"
BONN="$SHARED/data/rgbd_bonn_crowd_frames200to399"
MODEL="$SHARED/models/yolox_nano.onnx"
mkdir -p "$OUT"

run() {  # $1 = name, $2 = dataset, rest = extra args
  local name="$1" data="$2"; shift 2
  rm -rf "${OUT:?}/$name"
  "$BIN/dypho_run_dataset" --dataset "$data" --out "$OUT/$name" --quiet --save-masks "$@" > "$OUT/$name.log" 2>&1 ||
    { echo "fingerprint: $name failed (log: $OUT/$name.log)" >&2; tail -5 "$OUT/$name.log" >&2; return 1; }
  (cd "$OUT/$name" && find . -type f \( -name 'trajectory*.txt' -o -name keyframes.txt -o -name mask.txt \
      -o -name map.ply -o -name map.pcd -o -path './mask/*' \) -print0 | sort -z | xargs -0 sha256sum |
    sed "s|  \./|  $name/|")
}

for r in $RUNS; do
  case "$r" in
    synthetic)
      [ -d "$OUT/synthetic_seed1" ] ||
        "$BIN/dypho_synth" --out "$OUT/synthetic_seed1" --frames 300 --motion halfsphere --people 2 --seed 1 --no-bag > /dev/null
      run synthetic "$OUT/synthetic_seed1" --mask flow ;;
    fr1_flow) [ -d "$FR1" ] && run fr1_flow "$FR1" --mask flow ;;
    fr1_none) [ -d "$FR1" ] && run fr1_none "$FR1" --mask none ;;
    bonn_flow) [ -d "$BONN" ] && run bonn_flow "$BONN" --mask flow ;;
    bonn_detector)
      if [ -d "$BONN" ] && [ -f "$MODEL" ]; then
        printf 'mask:\n  yolo_model_path: "%s"\n' "$MODEL" > "$OUT/detector.yaml"
        run bonn_detector "$BONN" --mask flow --config "$OUT/detector.yaml"
      fi ;;
    *) echo "fingerprint: unknown run '$r'" >&2; exit 2 ;;
  esac
done
