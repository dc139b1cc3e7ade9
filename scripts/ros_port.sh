# Sourced by the scripts that start their own ROS master (scripts/test_launch_shutdown.sh,
# bench/graph_launch.sh, bench/stream_bandwidth.sh).
# free_ros_port: prints a TCP port for a new ROS master: nothing listens on it, and it lies below
# the kernel's ephemeral range (net.ipv4.ip_local_port_range, 32768 and up by default), where an
# outgoing connection of another process (a previous graph's node, say) may hold any port and
# roslaunch then fails with "Address already in use".
free_ros_port() {
  local low port
  low="$(cut -f1 /proc/sys/net/ipv4/ip_local_port_range 2> /dev/null || echo 32768)"
  [[ "$low" =~ ^[0-9]+$ && "$low" -gt 21024 ]] || low=32768
  for _ in $(seq 1 20); do
    port=$((20000 + RANDOM % (low - 20000)))
    # A connection that opens means a server listens there.
    if ! (exec 3<> "/dev/tcp/127.0.0.1/$port") 2> /dev/null; then
      echo "$port"
      return 0
    fi
  done
  echo "$port"
}
