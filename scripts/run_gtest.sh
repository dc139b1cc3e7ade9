#!/bin/bash
# Runs one gtest executable for ctest and tells ctest what happened: the executable's own exit
# status when a test failed; 77 (the tests' SKIP_RETURN_CODE) when everything that ran passed but
# a test skipped itself (GTEST_SKIP, e.g. ../shared missing), so ctest reports it as skipped and
# never as passed; 0 when every test ran and passed.
# Usage: run_gtest.sh EXECUTABLE [ARGS...]
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -u
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
"$@" 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
if [ "$status" -ne 0 ]; then exit "$status"; fi
if grep -q '^\[  SKIPPED \]' "$log"; then exit 77; fi
exit 0
