#!/bin/bash
# Writes a copy of a TUM-layout sequence with colour frames removed from rgb.txt, as a live graph
# that drops frames or a camera that loses some would give them. Images are linked, not copied.
# Usage: bench/drop_frames.sh SRC_DIR OUT_DIR every N [OFFSET]
#                                           (removes the frames k, counted from 1, with
#                                            (k + OFFSET) mod N = 0: every Nth; OFFSET default 0)
#        bench/drop_frames.sh SRC_DIR OUT_DIR random P SEED (removes each frame with probability P,
#                                                            never the first; repeatable per SEED)
#        bench/drop_frames.sh SRC_DIR OUT_DIR frames K[,K...] (removes the listed frames, counted
#                                                            from 0)
# Everything else (depth.txt, groundtruth.txt, masks, camera.yaml, the image folders) is linked.
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ] || [ $# -lt 4 ]; then
  awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; [ $# -ge 4 ]; exit $?
fi
set -euo pipefail
SRC="$(cd "$1" && pwd)"
OUT="$2"
MODE="$3"
mkdir -p "$OUT"
for f in "$SRC"/*; do
  if [ "$(basename "$f")" != rgb.txt ]; then ln -sfn "$f" "$OUT/$(basename "$f")"; fi
done
case "$MODE" in
  every) awk -v n="$4" -v o="${5:-0}" '/^#/ {print; next} {k++; if ((k + o) % n != 0) print}' "$SRC/rgb.txt" \
           > "$OUT/rgb.txt.tmp" ;;
  random) awk -v p="$4" -v seed="${5:?random needs a SEED}" 'BEGIN {srand(seed)} /^#/ {print; next}
            {k++; if (k == 1 || rand() >= p) print}' "$SRC/rgb.txt" > "$OUT/rgb.txt.tmp" ;;
  frames) awk -v list="$4" 'BEGIN {n = split(list, f, ","); for (i = 1; i <= n; i++) drop[f[i]] = 1}
            /^#/ {print; next} {if (!((k++) in drop)) print}' "$SRC/rgb.txt" > "$OUT/rgb.txt.tmp" ;;
  *) echo "drop_frames: mode must be 'every', 'random' or 'frames' (got '$MODE')" >&2; exit 2 ;;
esac
mv "$OUT/rgb.txt.tmp" "$OUT/rgb.txt"
kept=$(grep -vc '^#' "$OUT/rgb.txt")
total=$(grep -vc '^#' "$SRC/rgb.txt")
echo "drop_frames: kept $kept of $total frames in $OUT/rgb.txt"
