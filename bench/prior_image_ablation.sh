#!/bin/bash
# The paper's Table 3 with the in-process runner (R_d in the loop): prior-image mask (the static
# background model B_i and its consistency test; "R_d" = with the depth rendered from the Gaussian
# map blended in, background_tau 0.1; "B only" = background_tau 0) x adaptive features (the
# paper's relaxed feature test, relaxed_features) on TUM fr1/rpy (150 frames), the Bonn crowd
# frames (flow mask alone and with the YOLOX-nano detector) and a synthetic sequence (3 people,
# halfsphere camera, 300 frames). Prints one line per run: final ATE, online ATE, map PSNR, and
# how many frames used R_d. Runs are deterministic for a build.
# Usage: bench/prior_image_ablation.sh [BUILD_DIR] [OUT_DIR] [SEQUENCES...]
#   SEQUENCES: any of fr1 bonn bonn_det synth (default: all four)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-/tmp/dypho_prior_ablation}"
shift 2 || true
SEQUENCES=("${@:-fr1 bonn bonn_det synth}")
[ $# -eq 0 ] && SEQUENCES=(fr1 bonn bonn_det synth)
BIN="$BUILD/devel/lib/dypho_slam"
SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
MODEL="$SHARED/models/yolox_nano.onnx"
mkdir -p "$OUT"

if [[ " ${SEQUENCES[*]} " == *" synth "* ]] && [ ! -f "$OUT/synth_data/rgb.txt" ]; then
  "$BIN/dypho_synth" --out "$OUT/synth_data" --frames 300 --motion halfsphere --people 3 --seed 2 > /dev/null
fi

dataset() {
  case "$1" in
    fr1) echo "$SHARED/data/tum_fr1_rpy_first150" ;;
    bonn|bonn_det) echo "$SHARED/data/rgbd_bonn_crowd_frames200to399" ;;
    synth) echo "$OUT/synth_data" ;;
  esac
}

config() {  # $1 = file, $2 = sequence, $3 = prior (off/b_only/rd), $4 = relaxed features (true/false)
  {
    printf 'mask:\n'
    if [ "$2" = bonn_det ]; then printf '  yolo_model_path: "%s"\n' "$MODEL"; fi
    case "$3" in
      off) printf '  background_enabled: false\n' ;;
      b_only) printf '  background_enabled: true\n  background_tau: 0.0\n' ;;
      rd) printf '  background_enabled: true\n  background_tau: 0.1\n' ;;
    esac
    printf 'tracking:\n  relaxed_features: %s\n' "$4"
  } > "$1"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg)"
for seq in "${SEQUENCES[@]}"; do
  for prior in off b_only rd; do
    for relaxed in false true; do
      name="${seq}_${prior}_relaxed-${relaxed}"
      config "$OUT/$name.yaml" "$seq" "$prior" "$relaxed"
      log=$("$BIN/dypho_run_dataset" --dataset "$(dataset "$seq")" --out "$OUT/$name" --quiet \
              --config "$OUT/$name.yaml")
      ate=$(echo "$log" | grep -E "^ATE RMSE" | sed -E 's/ATE RMSE: +([0-9.]+) cm.*/\1/')
      online=$(echo "$log" | grep -E "^ATE online" | sed -E 's/ATE online: +([0-9.]+) cm.*/\1/')
      psnr=$(echo "$log" | grep -E "^map PSNR" | sed -E 's/map PSNR: +([0-9.]+) dB.*/\1/')
      rd=$(echo "$log" | grep -E "^mask prior" | sed -E 's/mask prior: +([0-9]+ of [0-9]+) frames.*/\1/')
      echo "$seq prior=$prior relaxed=$relaxed: ATE ${ate} cm (online ${online} cm), map PSNR ${psnr} dB, R_d on ${rd} frames"
    done
  done
done
