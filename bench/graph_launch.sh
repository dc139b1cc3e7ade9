# Sourced by the graph benchmarks (graph_soak.sh, realtime_graph.sh).
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/ros_port.sh"
# start_graph OUT [roslaunch args...]: starts `roslaunch dypho_slam tum_bag.launch ARGS` on a free
# port in its own process group (log in OUT/roslaunch.log), points ROS_MASTER_URI at it and waits
# for the nodelet manager. Sets launch_pid and manager_pid; exits 1 when the manager does not come.
start_graph() {
  local out="$1"; shift
  local port; port="$(free_ros_port)"
  setsid roslaunch -p "$port" --screen dypho_slam tum_bag.launch "$@" > "$out/roslaunch.log" 2>&1 &
  launch_pid=$!
  export ROS_MASTER_URI="http://localhost:$port"
  manager_pid=""
  for _ in $(seq 1 60); do
    # a child of this roslaunch (a previous run's manager may still be saving); roslaunch sets the
    # parameters (use_sim_time) before it starts the nodes
    manager_pid="$(pgrep -P "$launch_pid" -f "__name:=dypho_manager" | head -1 || true)"
    [[ -n "$manager_pid" ]] && return 0
    sleep 0.5
  done
  echo "$(basename "$0"): the nodelet manager did not start (see $out/roslaunch.log)" >&2
  exit 1
}
