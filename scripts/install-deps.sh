#!/usr/bin/env bash
# Installs the Debian packages placedb builds, tests and runs with.
# Idempotent: when every package is already present it changes nothing and asks no registry.
# Run as root (or with sudo available). Usage: scripts/install-deps.sh [--fuzz]
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libsqlite3-dev sqlite3
  libpq-dev postgresql  # maps on a PostgreSQL server; the tests start a throwaway one
  libopencv-dev
  libboost-serialization-dev
  libgtest-dev libgmock-dev
  nlohmann-json3-dev libcli11-dev libfmt-dev
  libplplot-dev plplot-driver-cairo
  python3 python3-dev pybind11-dev python3-numpy python3-pytest
  clang-format
  chromium  # opens `placedb report` pages in the headless browser test (tests/tools)
  # ROS 1 bags: the ROS project's reader and the headers its pluginlib include needs on Debian 12
  librosbag-storage-dev libclass-loader-dev librcpputils-dev librcutils-dev libament-index-cpp-dev
  python3-rosbag python3-sensor-msgs  # the tests write ROS 1 bags with ROS's own Python writer
  # The ROS 1 node (ros/): roscpp, topic_tools, the message definitions and ROS's generators;
  # its test runs rosmaster, roslaunch and rosbag play
  libroscpp-dev libtopic-tools-dev libsensor-msgs-dev libgeometry-msgs-dev libstd-msgs-dev
  ros-std-msgs ros-geometry-msgs ros-sensor-msgs python3-gencpp python3-genpy
  python3-rosmaster python3-roslaunch python3-rostopic python3-rosservice
  python3-venv  # `pip install ./python` in a fresh venv (tests/python)
)
if [[ "${1:-}" == "--fuzz" ]]; then
  packages+=(clang-14 libclang-rt-14-dev)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi

echo "install-deps: installing ${missing[*]}" >&2
SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install-deps: missing packages (${missing[*]}) and not root; run as root" >&2
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
