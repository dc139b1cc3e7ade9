#!/bin/bash
# roslaunch env-loader for <machine> tags (launch/distributed.launch): sets up the ROS environment
# of this checkout on a remote host, then runs the command roslaunch passes ("$@").
# Which setup.bash: $DYPHO_SETUP when set (in the remote login environment), else the devel space
# of a plain-CMake build (build/devel, scripts/build.sh), else that of a catkin workspace whose
# src/ holds this checkout (ws/devel).
# Usage: env_loader.sh COMMAND [ARGS...]   (roslaunch passes the command)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -e
export PATH=/usr/bin:/bin:$PATH   # a python first on PATH (pyenv, conda) breaks rospy
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
for setup in "${DYPHO_SETUP:-}" "$here/build/devel/setup.bash" "$here/../../devel/setup.bash"; do
  if [ -n "$setup" ] && [ -f "$setup" ]; then
    # shellcheck disable=SC1090
    source "$setup"
    exec "$@"
  fi
done
echo "env_loader.sh: no setup.bash found on $(hostname): build this checkout ($here) with" \
     "scripts/build.sh, or set DYPHO_SETUP to a devel or install space's setup.bash" >&2
exit 1
