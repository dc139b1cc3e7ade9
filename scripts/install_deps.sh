#!/bin/bash
# Installs every Debian bookworm package DyPho-SLAM needs to build, run and test. Idempotent:
# does nothing (and needs no network) when everything is already installed.
# Usage: scripts/install_deps.sh   (no arguments; installs with apt-get, as root or through sudo)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  catkin ros-message-generation ros-message-runtime libroscpp-dev
  libnodeletlib-dev libnodeletlib-tools pluginlib-dev libimage-transport-dev
  libcv-bridge-dev libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev
  libpcl-conversions-dev libpcl-dev libmessage-filters-dev librosbag-dev
  libsensor-msgs-dev libgeometry-msgs-dev libstd-msgs-dev libnav-msgs-dev
  ros-sensor-msgs ros-geometry-msgs ros-std-msgs ros-nav-msgs
  python3-sensor-msgs python3-geometry-msgs python3-tf2-msgs python3-nav-msgs
  libdiagnostic-updater-dev libdiagnostic-msgs-dev python3-diagnostic-msgs
  libeigen3-dev libopencv-dev libceres-dev libgtest-dev libyaml-cpp-dev
  librostest-dev python3-rostest ros-core rosbash python3-rosbag libstd-srvs-dev
  rviz xvfb imagemagick
  clang libclang-rt-14-dev clang-format universal-ctags
  python3-onnx python3-numpy python3-yaml
  opencv-doc
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null; then SUDO=sudo; else
    echo "install_deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; fi
fi
echo "install_deps: installing ${#missing[@]} packages: ${missing[*]}"
$SUDO apt-get update -q
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
