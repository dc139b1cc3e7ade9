#!/usr/bin/env bash
# play_then_wait.sh SECONDS COMMAND [ARGS...]
# tum_bag.launch's launch-prefix of the bag player: runs COMMAND (rosbag play ...), then waits
# SECONDS before it exits with COMMAND's exit code. The player is a required node, so the graph
# shuts down when it exits: the wait lets the frames still queued in the mask and tracking
# nodelets at the bag's end be tracked and published first. SIGINT/SIGTERM (Ctrl-C, roslaunch's
# shutdown) stop COMMAND and end the script at once.
set -u
seconds="$1"
shift
"$@" &
child=$!
trap 'kill -INT "$child" 2>/dev/null; wait "$child"; exit 130' INT
trap 'kill -TERM "$child" 2>/dev/null; wait "$child"; exit 143' TERM
wait "$child"
status=$?
trap 'exit 130' INT
trap 'exit 143' TERM
sleep "$seconds" &
wait $!
exit "$status"
