#!/bin/bash
# Bandwidth and rate of every stream that could cross hosts, measured with `rostopic bw` and
# `rostopic hz` while a RealSense-named bag plays at 1x into live_camera.launch.
# Usage: bench/stream_bandwidth.sh BAG OUT_DIR [SECONDS] [rendered_scale]
#   BAG: RealSense layout (dypho_dataset_to_bag --layout realsense), at least SECONDS + 5 s long.
#   SECONDS (default 25): measuring window; rostopic stops before the bag ends (its average is
#   bytes over "now - first message in the window", so it would decay after the last message).
#   rendered_scale (default 1): ~rendered_scale of the mapping nodelet for this run.
# Topics are measured in three runs of the bag (5 `rostopic bw` + one `rostopic hz` each) to keep
# the measuring processes' load on a 2-core machine down. Writes OUT_DIR/bw.tsv
# (topic, MB/s, mean message size, Hz) and the raw outputs. Needs `source build/devel/setup.bash`.
# BW_BATCHES="2" (indices, default "0 1 2") measures only those batches (2 = rendered views, clouds).
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
BAG="$(realpath "$1")"; OUT="$(realpath -m "$2")"; SECONDS_WINDOW="${3:-25}"; SCALE="${4:-1}"
mkdir -p "$OUT"
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/ros_port.sh"
port="$(free_ros_port)"
export ROS_MASTER_URI="http://localhost:$port" ROS_IP=127.0.0.1

# A config folder = config/ plus ~rendered_scale for the mapping nodelet.
cfg="$OUT/config"
rm -rf "$cfg"; cp -r "$(rospack find dypho_slam)/config" "$cfg"
printf '\n# bench/stream_bandwidth.sh\nrendered_scale: %s\n' "$SCALE" >> "$cfg/mapping.yaml"

BATCHES=(
  "/camera/color/image_raw /camera/aligned_depth_to_color/image_raw /camera/color/camera_info /dypho/mask /dypho/tracking_status"
  "/dypho/keyframe /dypho/keyframe_corrections /dypho/pose /dypho/path /tf"
  "/dypho/rendered/color /dypho/rendered/depth /dypho/rendered/depth_predicted /dypho/map_cloud /dypho/gaussian_cloud"
)

roscore -p "$port" > "$OUT/roscore.log" 2>&1 &
core_pid=$!
trap 'kill "$core_pid" 2>/dev/null || true' EXIT
sleep 3
: > "$OUT/bw.tsv"
for b in ${BW_BATCHES:-0 1 2}; do
  read -r -a topics <<< "${BATCHES[$b]}"
  setsid roslaunch dypho_slam live_camera.launch camera:=realsense rviz:=false config_dir:="$cfg" \
    > "$OUT/roslaunch_$b.log" 2>&1 &
  launch_pid=$!
  sleep 8   # nodelets up
  pids=()
  for t in "${topics[@]}"; do
    name="$(echo "$t" | tr '/' '_')"
    timeout -s INT "$SECONDS_WINDOW" rostopic bw -w 1000 "$t" > "$OUT/bw$name.txt" 2>&1 &
    pids+=($!)
  done
  timeout -s INT "$SECONDS_WINDOW" rostopic hz -w 1000 "${topics[@]}" > "$OUT/hz_$b.txt" 2>&1 &
  pids+=($!)
  rosbag play --quiet -d 1 "$BAG" > "$OUT/play_$b.log" 2>&1 &
  play_pid=$!
  for p in "${pids[@]}"; do wait "$p" || true; done
  kill -INT "$play_pid" 2>/dev/null || true; wait "$play_pid" 2>/dev/null || true
  kill -INT -- -"$launch_pid" 2>/dev/null || true; wait "$launch_pid" 2>/dev/null || true
  for t in "${topics[@]}"; do
    name="$(echo "$t" | tr '/' '_')"
    /usr/bin/python3 - "$t" "$OUT/bw$name.txt" "$OUT/hz_$b.txt" >> "$OUT/bw.tsv" <<'EOF'
import re, sys
topic, bw_file, hz_file = sys.argv[1:4]
def mb(value, unit):
    return float(value) * {"B": 1e-6, "KB": 1e-3, "MB": 1.0, "GB": 1e3}[unit]
bw = open(bw_file).read()
avg = re.findall(r"average: ([\d.]+)(B|KB|MB|GB)/s", bw)
mean = re.findall(r"mean: ([\d.]+)(B|KB|MB|GB) ", bw)
rate = "-"
for line in open(hz_file):  # multi-topic table: "topic rate min_delta max_delta std_dev window"
    f = line.split()
    if len(f) >= 2 and f[0] == topic:
        rate = f[1]
print("%s\t%s\t%s\t%s" % (topic, "%.3f" % mb(*avg[-1]) if avg else "no messages",
                          "%.4f" % mb(*mean[-1]) if mean else "-", rate))
EOF
  done
done
column -t -s $'\t' "$OUT/bw.tsv"
