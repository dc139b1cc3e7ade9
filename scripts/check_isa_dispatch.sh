#!/usr/bin/env bash
# check_isa_dispatch.sh LIBRARY
# The CPU tile kernels are compiled twice (baseline and AVX2+FMA) and chosen at run time. This
# checks the linked library: every function that uses AVX registers (ymm/zmm) or FMA/AVX2-only
# instructions must be one of the AVX2 kernels (namespace dypho::mapping::raster::avx2). Anything
# else would run AVX2 code on a CPU without it (SIGILL). Exit 0 clean, 1 on a finding, 2 on a
# usage or tool error.
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
lib="${1:-}"
if [[ -z "$lib" || ! -f "$lib" ]]; then
  echo "usage: $0 LIBRARY (got '${lib}')" >&2
  exit 2
fi
command -v objdump >/dev/null || { echo "objdump not found (binutils)" >&2; exit 2; }
objdump -d -C --no-show-raw-insn "$lib" | awk '
  /^[0-9a-f]+ <.*>:$/ { fn = $0; sub(/^[0-9a-f]+ </, "", fn); sub(/>:$/, "", fn); next }
  /%[yz]mm[0-9]|vfmadd|vfmsub|vfnmadd|vfnmsub|vpbroadcast|vperm2i128|vpgather|vgather/ {
    if (fn !~ /dypho::mapping::raster::avx2::/) bad[fn] = 1
    else avx2[fn] = 1
  }
  END {
    n = 0; for (f in bad) { print "AVX2 code outside the AVX2 kernels: " f; n++ }
    m = 0; for (f in avx2) m++
    printf "%d AVX2 kernel functions, %d other functions with AVX2 code\n", m, n
    exit n > 0 ? 1 : 0
  }'
