#!/usr/bin/env bash
# test_launch_shutdown.sh BAG OUT
# roslaunch shutdown, the two ways users stop a run, on tum_bag.launch at rate 1.0 with
# output_dir set:
#   1. Ctrl-C (SIGINT to roslaunch) while the bag plays and mapping trains;
#   2. the bag ends (the player is required: roslaunch shuts the graph down).
#   3. sessions: during case 2, ~save_session (tracking, which asks mapping for the map half)
#      must write a complete session; the shutdowns of cases 1 and 2 must each write one into
#      output_dir/session; then the bag again with session:= (case 2's) and
#      localization_only:=true must pose the frames in that map and leave it byte-identical,
#      with ~load_session (before the first frame) refusing a missing folder and loading the
#      session again.
# Each must end within 90 s, with exit code 0, no process that died (no segfault or abort at
# shutdown), and the outputs written completely: trajectory.txt with the posed frames and a
# map.ply, no temporary files left. Exit 0 when all pass.
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -uo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ros_port.sh"
bag="${1:-}"
out="${2:-}"
if [[ ! -f "$bag" || -z "$out" ]]; then
  echo "usage: $0 BAG OUT (bag '$bag' not found?)" >&2
  exit 2
fi
bag="$(realpath "$bag")"  # roslaunch runs nodes in ROS_HOME: a relative path would not resolve
out="$(realpath -m "$out")"
rm -rf "$out"
mkdir -p "$out"
failures=0
# Read once, as the rostests do (test/player_start.h): the player then reads it from memory.
cat "$bag" > /dev/null

start_delay=3.0  # tum_bag.launch start_delay: the player waits this long before it plays

# A complete session folder: its manifest, tracker.bin and map.ply (the manifest is written last).
check_session() {  # NAME DIR
  local name="$1" dir="$2" f
  for f in session.yaml tracker.bin map.ply; do
    [[ -s "$dir/$f" ]] || { echo "FAIL $name: no $dir/$f (session incomplete)" >&2; return 1; }
  done
  echo "ok   $name: session in $dir ($(grep -E '^(keyframes|gaussians):' "$dir/session.yaml" | tr '\n' ' '))"
}

wait_for_first_frame() {  # PORT PID
  local waited_for_frame=0
  until ROS_MASTER_URI="http://localhost:$1" timeout 5 rostopic echo -n 1 --noarr /dypho/tracking_status \
      > /dev/null 2>&1 || ((waited_for_frame >= 60)) || ! kill -0 "$2" 2>/dev/null; do
    sleep 1
    waited_for_frame=$((waited_for_frame + 1))
  done
}

run_case() {  # NAME PLAYED_S [roslaunch args] (Ctrl-C this long after the first tracked frame; 0 = let the bag end)
  local name="$1" interrupt_after="$2"
  shift 2
  # The output folder does not exist yet: the nodelets create it.
  local dir="$out/$name/run" log="$out/$name.log"
  local port; port="$(free_ros_port)"
  mkdir -p "$out/$name"
  local delay="$start_delay"
  # Localisation: time for the ~load_session calls before the first frame (a load restarts the
  # trajectory, so a load in mid-bag would leave too few poses to judge).
  [[ "$name" == localization_only ]] && delay=10.0
  # The synthetic bag's camera has a global shutter (tum_bag.launch assumes the TUM cameras' 30 ms).
  setsid roslaunch -p "$port" --screen dypho_slam tum_bag.launch bag:="$bag" output_dir:="$dir" \
    start_delay:="$delay" rolling_shutter_readout_ms:=0 "$@" > "$log" 2>&1 &
  local pid=$!
  if [[ "$name" == bag_ended ]]; then
    # A session saved while the bag plays, through the tracking nodelet's service. One client
    # that is up before the player starts, waits for the service and the first tracked frame and
    # calls at once: the bag plays 4 s, and starting rostopic and then rosservice after the first
    # frame took longer than that on a loaded 2-core machine (the graph had shut down). The
    # system Python, as rostopic has it: rospy is a Debian package.
    if ROS_MASTER_URI="http://localhost:$port" timeout 60 /usr/bin/python3 - > "$out/$name/save_session.txt" 2>&1 <<'PY' &&
import rospy
from dypho_slam.msg import TrackingStatus
from dypho_slam.srv import SaveMap
rospy.init_node("save_session_while_playing", anonymous=True, disable_signals=True)
rospy.wait_for_service("/dypho/tracking/save_session", timeout=55)
rospy.wait_for_message("/dypho/tracking_status", TrackingStatus, timeout=55)
print(rospy.ServiceProxy("/dypho/tracking/save_session", SaveMap)(directory="while_playing"))
PY
        grep -q "success: True" "$out/$name/save_session.txt"; then
      check_session save_session_while_playing "$dir/while_playing/session" || failures=$((failures + 1))
    else
      echo "FAIL save_session_while_playing: $(cat "$out/$name/save_session.txt")" >&2
      failures=$((failures + 1))
    fi
  fi
  if [[ "$name" == localization_only ]]; then
    # ~load_session before the player starts: a missing folder is refused and changes nothing;
    # the session itself loads again (mapping loads its map, tracking restores it at the first frame).
    local reply="" tries=0
    until grep -q "success:" <<< "$reply" || ((tries >= 40)); do
      sleep 0.5
      tries=$((tries + 1))
      reply=$(ROS_MASTER_URI="http://localhost:$port" timeout 30 rosservice call /dypho/tracking/load_session \
        "path: '$out/no_such_session'" 2>&1)
    done
    if ! grep -q "success: False" <<< "$reply" || ! grep -q "no session in" <<< "$reply"; then
      echo "FAIL load_session_missing: $reply" >&2
      failures=$((failures + 1))
    fi
    reply=$(ROS_MASTER_URI="http://localhost:$port" timeout 30 rosservice call /dypho/tracking/load_session \
      "path: '$out/bag_ended/run'" 2>&1)
    if grep -q "success: True" <<< "$reply"; then
      echo "ok   load_session: a missing folder refused, the session loaded again"
    else
      echo "FAIL load_session: $reply" >&2
      failures=$((failures + 1))
    fi
  fi
  if [[ "$interrupt_after" != 0 ]]; then
    # Counted from the first tracked frame, not from roslaunch's or the player's start: starting
    # the master and loading the nodelets takes 1-4 s on a loaded 2-core machine, and a player
    # whose libraries the machine had paged out was still in its start delay 4.5 s after its
    # process started (no frame played: trajectory.txt empty).
    wait_for_first_frame "$port" "$pid"
    sleep "$interrupt_after"
    kill -INT "$pid" 2>/dev/null
  fi
  local waited=0
  while kill -0 "$pid" 2>/dev/null && ((waited < 90)); do sleep 1; waited=$((waited + 1)); done
  if kill -0 "$pid" 2>/dev/null; then
    echo "FAIL $name: roslaunch still running 90 s after it was asked to stop" >&2
    kill -KILL -- "-$pid" 2>/dev/null
    failures=$((failures + 1))
    return
  fi
  wait "$pid"
  local code=$?
  local ok=1
  [[ $code -eq 0 ]] || { echo "FAIL $name: roslaunch exit code $code" >&2; ok=0; }
  # The player ending with exit code 0 is the normal end of case 2; anything else is a failure,
  # as is roslaunch having to escalate to SIGTERM/SIGKILL (outputs would not be written).
  if grep -E "escalating to SIG|exit code (-[0-9]+|[1-9][0-9]*)|Segmentation fault|core dumped|terminate called" "$log" >&2; then
    echo "FAIL $name: a process died at shutdown (lines above, $log)" >&2
    ok=0
  fi
  local poses=0
  [[ -f "$dir/trajectory.txt" ]] && poses=$(grep -vc '^#' "$dir/trajectory.txt")
  ((poses >= 20)) || { echo "FAIL $name: trajectory.txt has $poses poses (want >= 20)" >&2; ok=0; }
  [[ -s "$dir/map.ply" ]] || { echo "FAIL $name: no map.ply written" >&2; ok=0; }
  if find "$dir" -name '*.tmp*' | grep -q .; then
    echo "FAIL $name: temporary files left: $(find "$dir" -name '*.tmp*')" >&2
    ok=0
  fi
  if ((ok)); then
    echo "ok   $name: exit 0 after $waited s, $poses poses in trajectory.txt, map.ply $(stat -c %s "$dir/map.ply") bytes"
  else
    failures=$((failures + 1))
    echo "---- last lines of $log" >&2
    tail -20 "$log" >&2
  fi
}

run_case ctrl_c_while_playing 1.5  # the synthetic bag plays 4 s: Ctrl-C in its middle (1.5 s after its first tracked frame)
check_session shutdown_session_ctrl_c "$out/ctrl_c_while_playing/run/session" || failures=$((failures + 1))
run_case bag_ended 0
session="$out/bag_ended/run/session"
if check_session shutdown_session_bag_ended "$session"; then
  # Localisation only in yesterday's map: the frames are posed (run_case: >= 20 poses), no
  # session is written (nothing changed) and the map comes out as it went in, to the byte.
  run_case localization_only 0 session:="$out/bag_ended/run" localization_only:=true
  located="$out/localization_only/run"
  if ! cmp -s "$session/map.ply" "$located/map.ply"; then
    echo "FAIL localization_only: map.ply differs from the loaded session's" >&2
    failures=$((failures + 1))
  elif [[ -e "$located/session" ]]; then
    echo "FAIL localization_only: a session was written, the map did not change" >&2
    failures=$((failures + 1))
  elif ! grep -q "searching the loaded map" "$out/localization_only.log"; then
    echo "FAIL localization_only: the log never says the loaded map was searched" >&2
    failures=$((failures + 1))
  else
    echo "ok   localization_only: map.ply byte-identical to the session's"
  fi
else
  failures=$((failures + 1))
fi
exit $((failures > 0 ? 1 : 0))
