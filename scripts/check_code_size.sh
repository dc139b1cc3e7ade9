#!/bin/bash
# The size rules of the code, checked in CI (scripts/test.sh): no function over 80 lines and no
# file over 600 lines in the cores, the nodelets, the pipeline and the tools. Tests, benchmarks,
# the synthetic scene generator and third-party code are left out. Functions are found with
# universal-ctags (package universal-ctags); a lambda counts toward the function around it.
# Usage: scripts/check_code_size.sh [--list N]   (--list N: every function over N lines, no check)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
MAX_FUNCTION_LINES=80
MAX_FILE_LINES=600
LIST=""
if [ "${1:-}" = "--list" ]; then LIST="${2:?--list needs a number of lines}"; fi
if ! ctags --version 2>/dev/null | grep -q "Universal Ctags"; then
  echo "check_code_size: universal-ctags is needed (sudo apt-get install universal-ctags)" >&2
  exit 2
fi
source "$ROOT/scripts/source_files.sh"
mapfile -t FILES < <(source_files '^dypho_[a-z]+/(src|include|standalone)/.*\.(cpp|h|hpp|cu|cuh)$' \
  '^tools/(src|include|apps)/.*\.(cpp|h|hpp|cu|cuh)$' | grep -v -E '/test/|synthetic_')
if [ ${#FILES[@]} -eq 0 ]; then echo "check_code_size: no source file found under $ROOT" >&2; exit 1; fi
functions() {  # prints: lines name file:line
  ctags -x --c++-kinds=f --fields=+ne --_xformat='%N	%n	%e	%F' --language-force=C++ "${FILES[@]}" 2>/dev/null |
    awk -F'\t' '{ name = $1; gsub(/ /, "", name); print $3 - $2 + 1, name, $4 ":" $2 }' | sort -rn
}
if [ -n "$LIST" ]; then functions | awk -v n="$LIST" '$1 > n'; exit 0; fi
fail=0
while read -r lines name where; do
  echo "check_code_size: $where: $name is $lines lines (at most $MAX_FUNCTION_LINES): split it into named steps"
  fail=1
done < <(functions | awk -v n="$MAX_FUNCTION_LINES" '$1 > n')
for f in "${FILES[@]}"; do
  n=$(wc -l < "$f")
  if [ "$n" -gt "$MAX_FILE_LINES" ]; then
    echo "check_code_size: $f has $n lines (at most $MAX_FILE_LINES)"
    fail=1
  fi
done
if [ "$fail" = 0 ]; then echo "check_code_size: ${#FILES[@]} files, every function <= $MAX_FUNCTION_LINES lines, every file <= $MAX_FILE_LINES lines"; fi
exit "$fail"
