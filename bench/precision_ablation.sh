#!/bin/bash
# Tracking precision, each part on and off: the offline runner (`--no-map`, deterministic) on the
# shared sequences whole, with every 15th frame removed and with 10 % removed at random
# (bench/drop_frames.sh), and on the generator's hard case when its folder is given. Prints one
# line per run: sequence, frames, configuration, ATE of the final trajectory [cm], its max [cm],
# median tracking and dense-refinement ms per frame.
# Usage: bench/precision_ablation.sh [BUILD_DIR] [OUT_DIR]
#   DYPHO_ABLATION_CONFIGS: configurations to run (default: features wide dense_only dense_all
#     dense), e.g. "features dense"; the others below: global_ba (on by default since 2026-12-01),
#     no_global_ba, fuse, global_shutter (the
#     rolling-shutter model off), blur (keypoints weighted by a 15 ms exposure's streaks),
#     no_blur (by none: the 4 ms default off), blur_ungated (the 4 ms on slow frames too),
#     keyframes_1_5 (keyframes postponed above 1.5 deg/frame, the limit before 4), rate_fixed,
#     rate_ratio_0_25 and rate_ratio_0_5 (the rolling-shutter rate prior's width fixed at
#     0.15 rad/s, or widened to 0.25 / 0.5 times the motion model's rate), no_fit and
#     no_motion_tolerance (the mask's parts that serve tracking off), local_map_20 and
#     local_map_40 (frames tracked against 20 or 40 covisible keyframes' points, not 10),
#     local_ba_10 (local BA over 10 keyframes, not 5), kf_ratio_0_75 and kf_ratio_0_5 (a new
#     keyframe below 75 % or 50 % of the keyframe's points tracked, not 60 %), kf_sharp_0_75
#     (75 % on sharp frames of a moving camera only), no_smoothing (the saved trajectory's
#     positions not fitted in time), same_level_sharp (the projection search's ratio test only
#     between candidates of the same pyramid level, for verified points on sharp frames of a
#     moving camera), same_level_always (the same on every frame of a moving camera), no_nearby
#     (the local map without the keyframes of the reference's view: covisible keyframes only),
#     no_static_check (no dense check of the tracked pose against the reference keyframe),
#     no_keyframe_wait (keyframes also on poses the static check disputes),
#     no_ba_blur (bundle adjustment takes blurred keyframes' keypoints as sharp),
#     frame_refinement (each frame with at most 5 % of it masked optimised again against the
#     final map at the end), frame_refinement_all (every frame, movers in view or not)
#   DYPHO_ABLATION_DROPS: frame removals (default: "whole every15 random10")
#   DYPHO_ABLATION_SEQUENCES: (default: "fr1_flow fr1_none bonn_flow bonn_detector synth_hard");
#     also synth_long: the same hard case over 900 frames (seed 4), sweeping the same view again
#   DYPHO_SYNTH_HARD: a dypho_synth folder for synth_hard (default: generated into OUT_DIR)
# Also appends one row per run to OUT_DIR/ablation.tsv (the columns of docs/results/ablation.tsv,
# which scripts/results_table.py renders into docs/results.md).
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
export PATH=/usr/bin:/bin:$PATH
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-/tmp/dypho_precision}"
BIN="$BUILD/devel/lib/dypho_slam"
SHARED="${DYPHO_SHARED_DIR:-$ROOT/../shared}"
FR1="$SHARED/data/tum_fr1_rpy_first150"
BONN="$SHARED/data/rgbd_bonn_crowd_frames200to399"
MODEL="$SHARED/models/yolox_nano.onnx"
mkdir -p "$OUT"

# name -> tracking options (YAML lines under tracking:); `features` is the defaults.
declare -A CONFIG=(
  [features]=''
  [wide]=$'  wide_search_radius_px: 45'
  [dense_only]=$'  dense_refinement: true\n  dense_feature_prior_weight: 0'
  [dense_all]=$'  dense_refinement: true\n  dense_max_frame_rotation_deg: 180'
  [dense]=$'  dense_refinement: true'
  [global_ba]=$'  global_ba_at_end: true'
  [no_global_ba]=$'  global_ba_at_end: false'
  [fuse]=$'  fuse_keyframes: 10'
  [global_shutter]=$'  rolling_shutter_readout_ms: 0'
  [blur]=$'  motion_blur_exposure_ms: 15'
  [no_blur]=$'  motion_blur_exposure_ms: 0'
  [blur_ungated]=$'  motion_blur_min_rate_rad_s: 0'
  [keyframes_1_5]=$'  keyframe_max_frame_rotation_deg: 1.5'
  [rate_fixed]=$'  rolling_shutter_rate_sigma_ratio: 0'
  [rate_ratio_0_25]=$'  rolling_shutter_rate_sigma_ratio: 0.25'
  [rate_ratio_0_5]=$'  rolling_shutter_rate_sigma_ratio: 0.5'
  [local_map_20]=$'  local_map_keyframes: 20'
  [local_map_40]=$'  local_map_keyframes: 40'
  [local_ba_10]=$'  local_ba_keyframes: 10'
  [kf_ratio_0_75]=$'  keyframe_min_tracked_ratio: 0.75'
  [kf_ratio_0_5]=$'  keyframe_min_tracked_ratio: 0.5'
  [kf_sharp_0_75]=$'  keyframe_sharp_tracked_ratio: 0.75'
  [no_smoothing]=$'  trajectory_smoothing_s: 0'
  [same_level_sharp]=$'  ratio_test_same_level_max_rotation_deg: 1'
  [same_level_always]=$'  ratio_test_same_level_max_rotation_deg: 180'
  [no_nearby]=$'  local_map_nearby_keyframes: 0'
  [no_static_check]=$'  static_check: false'
  [no_keyframe_wait]=$'  keyframe_wait_while_disputed: false'
  [no_ba_blur]=$'  motion_blur_in_bundle_adjustment: false'
  [frame_refinement]=$'  final_frame_refinement: true'
  [frame_refinement_all]=$'  final_frame_refinement: true\n  final_frame_refinement_max_masked_fraction: 1'
)
# name -> mask options (YAML lines under mask:), for the mask's parts that serve tracking.
declare -A MASK_CONFIG=(
  [no_fit]=$'  flow_fit_rigid_motion: false'
  [no_motion_tolerance]=$'  background_motion_tolerance: 0'
)
CONFIGS=(${DYPHO_ABLATION_CONFIGS:-features wide dense_only dense_all dense})
DROPS=(${DYPHO_ABLATION_DROPS:-whole every15 random10})
SEQUENCES=(${DYPHO_ABLATION_SEQUENCES:-fr1_flow fr1_none bonn_flow bonn_detector synth_hard})

# The generator's hard case kinect-fast (2 people) in folder $1, $2 frames, seed $3: generated once.
kinect_fast() {
  if [ ! -f "$1/rgb.txt" ]; then
    "$BIN/dypho_synth" --out "$1" --frames "$2" --hard-case kinect-fast --people 2 --seed "$3" --no-bag > /dev/null
  fi
  echo "$1"
}

dataset() {  # $1 = sequence, $2 = drop -> folder
  local src
  case "$1" in
    fr1_*) src="$FR1" ;;
    bonn_*) src="$BONN" ;;
    synth_hard) src="$(kinect_fast "${DYPHO_SYNTH_HARD:-$OUT/synth_hard}" 300 1)" ;;
    synth_long) src="$(kinect_fast "$OUT/synth_long" 900 4)" ;;
  esac
  case "$2" in
    whole) echo "$src" ;;
    every15) bash "$ROOT/bench/drop_frames.sh" "$src" "$OUT/data/$1_$2" every 15 > /dev/null; echo "$OUT/data/$1_$2" ;;
    random10) bash "$ROOT/bench/drop_frames.sh" "$src" "$OUT/data/$1_$2" random 0.1 7 > /dev/null; echo "$OUT/data/$1_$2" ;;
  esac
}

stats() {  # $1 = run folder: median tracking ms, median dense ms
  /usr/bin/python3 - "$1/timing.csv" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print(f"{statistics.median(float(r['tracking_ms']) for r in rows):.1f} "
      f"{statistics.median(float(r.get('dense_ms', 0) or 0) for r in rows):.1f}")
PY
}

MACHINE="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
COMMIT="$(git -C "$ROOT" rev-parse --short=10 HEAD 2>/dev/null || echo none)"
if [ -n "$(git -C "$ROOT" status --porcelain --untracked-files=no 2>/dev/null)" ]; then COMMIT="$COMMIT+changes"; fi
TSV="$OUT/ablation.tsv"
[ -f "$TSV" ] || printf 'date\tsequence\tdrop\tconfig\toptions\tate_cm\tmax_cm\ttrack_ms\tdense_ms\tmachine\tcommit\n' > "$TSV"
echo "machine: $MACHINE, commit $COMMIT"
printf '%-14s %-9s %-11s %8s %8s %9s %9s\n' sequence frames config ATE_cm max_cm track_ms dense_ms
for seq in "${SEQUENCES[@]}"; do
  for drop in "${DROPS[@]}"; do
    data="$(dataset "$seq" "$drop")"
    mask=flow; [ "$seq" = fr1_none ] && mask=none
    for cfg in "${CONFIGS[@]}"; do
      name="${seq}_${drop}_${cfg}"
      { printf 'mask:\n'
        if [ "$seq" = bonn_detector ]; then printf '  yolo_model_path: "%s"\n' "$MODEL"; fi
        printf '%s\ntracking:\n%s\n' "${MASK_CONFIG[$cfg]:-}" "${CONFIG[$cfg]:-}"; } > "$OUT/$name.yaml"
      "$BIN/dypho_run_dataset" --dataset "$data" --out "$OUT/$name" --quiet --no-map --mask "$mask" \
        --config "$OUT/$name.yaml" > "$OUT/$name.log" 2>&1 || { echo "$name: failed (see $OUT/$name.log)"; continue; }
      ate=$(grep -m1 -E "^ATE RMSE" "$OUT/$name.log" | sed -E 's/^ATE RMSE: *([0-9.]+) cm.*/\1/')
      max=$(grep -m1 -E "^ATE RMSE" "$OUT/$name.log" | sed -E 's/.*max ([0-9.]+),.*/\1/')
      read -r track_ms dense_ms < <(stats "$OUT/$name")
      printf '%-14s %-9s %-11s %8s %8s %9s %9s\n' "$seq" "$drop" "$cfg" "$ate" "$max" "$track_ms" "$dense_ms"
      options="$(printf '%s\n%s' "${MASK_CONFIG[$cfg]:-}" "${CONFIG[$cfg]:-}" | sed -E 's/^ +//' | { grep -v '^$' || true; } | paste -sd ';' - | sed 's/;/; /g')"
      printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(date +%F)" "$seq" "$drop" "$cfg" "${options:-defaults}" \
        "$ate" "$max" "$track_ms" "$dense_ms" "$MACHINE" "$COMMIT" >> "$TSV"
    done
  done
done
