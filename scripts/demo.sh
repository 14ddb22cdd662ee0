#!/usr/bin/env bash
# The main job: the ROS demo on Manhattan M3500 with 10 % injected outliers
# (seed 1): dataset_player (stand-in front-end) -> agnc_pgo back-end nodelet.
#  - with a display ($DISPLAY set): opens rviz (Ctrl-C to stop);
#  - headless: runs under Xvfb with software GL, prints the final status table
#    and saves an rviz screenshot to doc/demo.png.
# Installs missing Debian packages and builds first. The offline replay of the
# same run is build/devel/lib/agnc_pgo/agnc_pgo_replay (see README).
# Environment: AGNC_DEMO_RATE (entries/s, default 120), AGNC_DEMO_PORT (master port).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

agnc_install_dependencies
agnc_build

export PATH="/usr/bin:$PATH" PYENV_VERSION=system
source "$AGNC_BUILD/devel/setup.bash"
port="${AGNC_DEMO_PORT:-11391}"
export ROS_MASTER_URI="http://localhost:$port"
args=(outliers:=10 seed:=1 "rate:=${AGNC_DEMO_RATE:-120}")

if [ -n "${DISPLAY:-}" ]; then
  exec roslaunch -p "$port" agnc_pgo demo.launch rviz:=true "${args[@]}"
fi
"$AGNC_ROOT/scripts/screenshot.sh" "$AGNC_ROOT/doc/demo.png" "${args[@]}"
