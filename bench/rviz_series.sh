#!/usr/bin/env bash
# rviz_series.sh BAG OUT.jpg [--at "S1 S2 ..."] [--detector MODEL.onnx]
#
# What a user watching rviz sees while the map builds: plays BAG through
# `roslaunch dypho_slam tum_bag.launch rviz:=true` at 1x, with rviz on a virtual display (Xvfb,
# 1200x750), takes a screenshot of it at about S seconds of playback for each S of --at (default
# "2 5 9"), and writes them side by side, each at half size, into OUT.jpg, and their image panels
# at full size side by side into OUT_panels.jpg; the full screenshots are kept beside it
# (OUT_<S>s.png). rviz's panels: input colour, the map rendered at the tracked
# pose, the dynamic mask, the rendered depth, the path, tf and the map's clouds.
# Needs the catkin build and its environment (source build/devel/setup.bash), Xvfb and
# ImageMagick (scripts/install_deps.sh installs both).
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/bench/graph_launch.sh"
usage() { sed -n '2p' "$0" | sed 's/^# //' >&2; exit 2; }
[[ $# -ge 2 ]] || usage
bag="$(realpath "$1")" target="$(realpath -m "$2")"; shift 2
times="2 5 9" detector=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --at) times="$2"; shift 2 ;;
    --detector) detector="$(realpath "$2")"; shift 2 ;;
    *) usage ;;
  esac
done
[[ -f "$bag" ]] || { echo "rviz_series.sh: no bag at $bag" >&2; exit 2; }
work="$(mktemp -d)"
display=":$((90 + RANDOM % 9))"
Xvfb "$display" -screen 0 1200x750x24 -nolisten tcp > "$work/xvfb.log" 2>&1 &
xvfb_pid=$!
cleanup() { kill -INT -- -"${launch_pid:-0}" 2>/dev/null || true; kill "$xvfb_pid" 2>/dev/null || true; }
trap cleanup EXIT
export DISPLAY="$display"
delay=8.0
cat "$bag" > /dev/null  # read once: the player must not wait for the disk (see realtime_graph.sh)
start_graph "$work" bag:="$bag" rate:=1.0 rviz:=true output_dir:="$work/run" yolo_model:="$detector" \
  start_delay:="$delay"
started=$(date +%s.%N)
shots=()
for s in $times; do
  wait_s="$(python3 -c "print(max(0.0, $started + $delay + $s - $(date +%s.%N)))")"
  sleep "$wait_s"
  shot="${target%.*}_${s}s.png"
  import -window root "$shot"
  shots+=("$shot")
  echo "rviz_series.sh: $shot (about $s s of playback)"
done
wait "$launch_pid" || true
trap - EXIT
kill "$xvfb_pid" 2>/dev/null || true
convert "${shots[@]}" -resize 50% +append -quality 85 "$target"
# The image panels (rendered depth and colour, mask, input) of each shot at full size, side by side.
convert "${shots[@]}" -crop 342x523+0+62 +repage +append -quality 85 "${target%.*}_panels.jpg"
echo "rviz_series.sh: $target, ${target%.*}_panels.jpg"
