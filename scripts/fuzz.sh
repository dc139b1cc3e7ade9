#!/bin/bash
# Builds the libFuzzer targets (fuzz/, clang) and runs each for about SECONDS of one core on a
# copy of its seed corpus (fuzz/corpus/<name>; new inputs land in the copy, not in the
# repository). Exit 0 only when no target crashed, leaked or tripped a sanitizer (the crashing
# input is kept in OUT).
# Usage: fuzz.sh [SECONDS_PER_TARGET] [OUT_DIR]        (default 20 s, build-fuzz/)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_PER_TARGET="${1:-20}"
OUT="${2:-$ROOT/build-fuzz}"
mkdir -p "$OUT"
CC=clang CXX=clang++ cmake -S "$ROOT/fuzz" -B "$OUT" -DCMAKE_BUILD_TYPE=None > "$OUT/configure.log" 2>&1 \
  || { cat "$OUT/configure.log"; exit 1; }
cmake --build "$OUT" -j "${DYPHO_JOBS:-$(nproc)}"
JOBS="${DYPHO_JOBS:-$(nproc)}"
# One target: fuzzes its corpus copy for WALL_SECONDS beside the others; its summary goes to
# $OUT/<target>.result, its log to $OUT/<target>.log.
fuzz_one() {
  local target="fuzz_${1%%:*}" corpus="$OUT/corpus_${1##*:}"
  rm -rf "$corpus" && cp -r "$ROOT/fuzz/corpus/${1##*:}" "$corpus"
  if (cd "$OUT" && "./$target" -max_total_time="$WALL_SECONDS" -rss_limit_mb=2048 -timeout=10 \
        -print_final_stats=1 "$corpus" > "$OUT/$target.log" 2>&1); then
    echo "fuzz.sh: $target for ${WALL_SECONDS} s beside the others: $(grep -E "^stat::number_of_executed_units|^Done" \
      "$OUT/$target.log" | tr '\n' ' ')" > "$OUT/$target.result"
  else
    echo "fuzz.sh: $target FOUND A PROBLEM (input saved in $OUT, log $OUT/$target.log)" > "$OUT/$target.result"
  fi
}
PAIRS=(gaussian_ply:ply tum_lists:tum_lists camera_yaml:camera_yaml options_yaml:options_yaml
       tracker_session:tracker_session)
# The targets are single-threaded and all run side by side on the JOBS cores, for as long as
# gives each SECONDS of a core (libFuzzer's limit is wall time). In rounds of JOBS targets, the
# last round of an odd count left a core idle.
WALL_SECONDS=$(( (SECONDS_PER_TARGET * ${#PAIRS[@]} + JOBS - 1) / JOBS ))
rm -f "$OUT"/fuzz_*.result
for pair in "${PAIRS[@]}"; do fuzz_one "$pair" & done
wait
status=0
for pair in "${PAIRS[@]}"; do
  target="fuzz_${pair%%:*}"
  cat "$OUT/$target.result"
  if grep -q "FOUND A PROBLEM" "$OUT/$target.result"; then
    tail -40 "$OUT/$target.log" >&2
    status=1
  fi
done
exit "$status"
