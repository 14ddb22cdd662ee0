#!/usr/bin/env bash
# Installs what agnc_pgo needs (Debian 12 packages, only if missing), then
# configures and builds the package in ./build (Release).
# Sourced by demo.sh and test.sh; can be run on its own.
set -eo pipefail

AGNC_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
AGNC_BUILD="${AGNC_BUILD:-$AGNC_ROOT/build}"

AGNC_PACKAGES=(
  build-essential cmake
  catkin ros-message-generation ros-message-runtime ros-std-msgs ros-geometry-msgs
  ros-nav-msgs ros-visualization-msgs ros-std-srvs
  libroscpp-dev libstd-msgs-dev libgeometry-msgs-dev libvisualization-msgs-dev libnav-msgs-dev
  libstd-srvs-dev libnodeletlib-dev libnodeletlib-tools pluginlib-dev libtf2-ros-dev
  libtf2-geometry-msgs-dev libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libgtest-dev librostest-dev python3-rostest python3-roslaunch rosout rosbash
  python3-rostopic python3-rosnode python3-rosservice
  python3-geometry-msgs python3-nav-msgs python3-std-srvs python3-visualization-msgs python3-tf2-ros
  libceres-dev libsuitesparse-dev libeigen3-dev libboost-dev
  librviz-dev rviz libinteractive-markers-dev xvfb xauth imagemagick xdotool libgl1-mesa-dri
  python3-matplotlib python3-numpy python3-pytest
  clang-14 libclang-rt-14-dev
)

agnc_install_dependencies() {
  local missing=()
  for p in "${AGNC_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "[agnc_pgo] installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
    -o Dpkg::Options::=--force-unsafe-io "${missing[@]}" >/dev/null
}

# The install prefix is build/.install: roslaunch finds `agnc_pgo demo.launch`
# by walking the package directory (skipping only hidden directories), so
# an install space under build/install would be a second demo.launch.
agnc_build() {
  export ROS_HOME="$AGNC_BUILD/ros_home"
  mkdir -p "$ROS_HOME"
  cmake -S "$AGNC_ROOT" -B "$AGNC_BUILD" -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$AGNC_BUILD/.install" \
    -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
  local log="$AGNC_BUILD/build.log"
  if ! cmake --build "$AGNC_BUILD" -j"$(nproc)" "$@" >"$log" 2>&1; then
    grep -E -A5 "error|Error" "$log" | head -60
    echo "[agnc_pgo] build failed; full log: $log" >&2
    return 1
  fi
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  agnc_install_dependencies
  agnc_build
fi
