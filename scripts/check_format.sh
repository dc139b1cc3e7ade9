#!/bin/bash
# The C++ and CUDA files follow .clang-format (Google style, 120 columns), checked in CI with
# Debian bookworm's clang-format 14 (package clang-format): other versions format some
# constructs differently, so another major version is refused rather than trusted.
# Usage: scripts/check_format.sh [--fix]   (--fix: rewrites the files in place instead)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
FORMAT="${CLANG_FORMAT:-clang-format}"
version="$("$FORMAT" --version 2>/dev/null | sed -n 's/.*clang-format version \([0-9]*\)\..*/\1/p')"
if [ "$version" != "14" ]; then
  echo "check_format: needs clang-format 14 (Debian bookworm: sudo apt-get install clang-format); found '${version:-none}'" >&2
  exit 2
fi
source "$ROOT/scripts/source_files.sh"
mapfile -t FILES < <(source_files '\.(cpp|h|hpp|cu|cuh)$')
if [ ${#FILES[@]} -eq 0 ]; then echo "check_format: no C++ file found under $ROOT" >&2; exit 1; fi
if [ "${1:-}" = "--fix" ]; then
  "$FORMAT" -i "${FILES[@]}"
  echo "check_format: formatted ${#FILES[@]} files"
  exit 0
fi
if ! "$FORMAT" --dry-run -Werror "${FILES[@]}" 2> /tmp/check_format.$$.log; then
  grep -E "^[^ ].*: (error|warning):" /tmp/check_format.$$.log | cut -d: -f1 | sort -u | sed 's/^/check_format: not formatted: /' | head -50
  echo "check_format: run scripts/check_format.sh --fix (clang-format 14) and commit the result" >&2
  rm -f /tmp/check_format.$$.log
  exit 1
fi
rm -f /tmp/check_format.$$.log
echo "check_format: ${#FILES[@]} files follow .clang-format"
