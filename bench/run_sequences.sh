#!/bin/bash
# Runs dypho_run_dataset on the shared real sequences and a synthetic one; prints ATE and the
# median ms per stage (the numbers in docs/journal/benchmarks-2026.md).
# Usage: bench/run_sequences.sh [BUILD_DIR] [OUT_DIR]     (../shared must sit beside the repo)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-/tmp/dypho_bench}"
BIN="$BUILD/devel/lib/dypho_slam"
SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
mkdir -p "$OUT"

summary() {  # $1 = run folder
  /usr/bin/python3 - "$1" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1] + "/timing.csv")))
cols = ["mask_ms", "features_ms", "matching_ms", "pnp_ms", "refine_ms", "tracking_ms", "mapping_ms", "total_ms"]
print("  median ms/frame: " + ", ".join(f"{c[:-3]} {statistics.median(float(r[c]) for r in rows):.1f}" for c in cols))
print(f"  frames {len(rows)}, keyframes {sum(int(r['is_keyframe']) for r in rows)}, "
      f"not tracked {sum(r['state'] != 'OK' for r in rows)}, "
      f"mean masked fraction {statistics.mean(float(r['masked_fraction']) for r in rows):.3f}")
PY
}

run() {  # $1 = name, $2 = dataset, rest = extra args
  local name="$1" data="$2"; shift 2
  echo "== $name ($*)"
  "$BIN/dypho_run_dataset" --dataset "$data" --out "$OUT/$name" --quiet "$@" | grep -E "ATE|RPE"
  summary "$OUT/$name"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
if [ -d "$SHARED/data/tum_fr1_rpy_first150" ]; then
  run fr1_flow "$SHARED/data/tum_fr1_rpy_first150" --mask flow
  run fr1_nomask "$SHARED/data/tum_fr1_rpy_first150" --mask none
fi
if [ -d "$SHARED/data/rgbd_bonn_crowd_frames200to399" ]; then
  run bonn_flow "$SHARED/data/rgbd_bonn_crowd_frames200to399" --mask flow
  run bonn_nomask "$SHARED/data/rgbd_bonn_crowd_frames200to399" --mask none
fi
"$BIN/dypho_synth" --out "$OUT/synth_halfsphere" --frames 300 --motion halfsphere --people 2 --seed 1 --no-bag > /dev/null
run synth_flow "$OUT/synth_halfsphere" --mask flow
run synth_gt "$OUT/synth_halfsphere" --mask gt
run synth_nomask "$OUT/synth_halfsphere" --mask none
