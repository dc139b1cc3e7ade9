#!/bin/bash
# Runs one gtest executable for ctest and tells ctest what happened: the executable's own exit
# status when a test failed; 77 (the tests' SKIP_RETURN_CODE) when everything that ran passed but
# a test skipped itself (GTEST_SKIP, e.g. ../shared missing), so ctest reports it as skipped and
# never as passed; 0 when every test ran and passed.
# With --shards N (N > 1) the executable runs as N gtest shards side by side (GTEST_TOTAL_SHARDS,
# GTEST_SHARD_INDEX): for whole-system tests whose runs each keep about one core busy. Each
# shard's output is printed whole, in order, after all have ended; the status is the first
# failing shard's.
# Usage: run_gtest.sh [--shards N] EXECUTABLE [ARGS...]
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -u
shards=1
if [ "${1:-}" = "--shards" ]; then
  shards="${2:?run_gtest.sh: --shards needs a count}"
  shift 2
fi
logs="$(mktemp -d)"
trap 'rm -rf "$logs"' EXIT
status=0
if [ "$shards" -le 1 ]; then
  "$@" 2>&1 | tee "$logs/0"
  status=${PIPESTATUS[0]}
else
  pids=()
  for ((i = 0; i < shards; i++)); do
    GTEST_TOTAL_SHARDS="$shards" GTEST_SHARD_INDEX="$i" "$@" > "$logs/$i" 2>&1 &
    pids+=("$!")
  done
  for ((i = 0; i < shards; i++)); do
    wait "${pids[$i]}"
    shard_status=$?
    echo "run_gtest.sh: shard $((i + 1)) of $shards (exit $shard_status):"
    cat "$logs/$i"
    if [ "$status" -eq 0 ] && [ "$shard_status" -ne 0 ]; then status=$shard_status; fi
  done
fi
if [ "$status" -ne 0 ]; then exit "$status"; fi
if grep -q '^\[  SKIPPED \]' "$logs"/*; then exit 77; fi
exit 0
