#!/bin/bash
# Tracking time and ATE against the keypoint budget on TUM fr1/rpy (tracker alone, no mask).
# Usage: bench/tracking_feature_scaling.sh [BUILD_DIR]
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
for n in 250 500 1000 2000; do
  echo "num_features $n: $("$BUILD/devel/lib/dypho_slam/tracking_bench_sequence" \
    --dataset "$SHARED/data/tum_fr1_rpy_first150" --set num_features "$n" | tail -1)"
done
