#!/usr/bin/env bash
# Runs the ROS demo (dataset_player -> back-end -> rviz) headless, waits until
# the back-end has settled, prints the final status table and saves an rviz
# screenshot.  usage: screenshot.sh OUT.png [roslaunch args, e.g. rate:=120]
# Without $DISPLAY it re-runs itself under Xvfb (software GL). Expects the
# package to be built and build/devel/setup.bash sourced (demo.sh does this).
set -eo pipefail
out="${1:?usage: screenshot.sh OUT.png [roslaunch args]}"
shift
if [ -z "${DISPLAY:-}" ]; then
  exec xvfb-run -a -s "-screen 0 1280x800x24" "$0" "$out" "$@"
fi
export LIBGL_ALWAYS_SOFTWARE=1 PATH="/usr/bin:$PATH" PYENV_VERSION=system
# A master of its own on a free port (AGNC_DEMO_PORT to choose one): demos run
# side by side must not share a master.
port="${AGNC_DEMO_PORT:-$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')}"
export ROS_MASTER_URI="http://localhost:$port"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
log="$(mktemp -t agnc_demo_roslaunch.XXXXXX.log)"  # one per run

roslaunch -p "$port" agnc_pgo demo.launch rviz:=true output:=log "$@" >"$log" 2>&1 &
launch_pid=$!
cleanup() { kill -INT "$launch_pid" 2>/dev/null || true; wait "$launch_pid" 2>/dev/null || true; }
trap cleanup EXIT

status=0
/usr/bin/python3 "$here/ros_status.py" --timeout "${AGNC_DEMO_TIMEOUT:-170}" || status=$?
if [ "$status" -ne 0 ]; then
  echo "[agnc_pgo] the demo failed; the end of its roslaunch log ($log):" >&2
  grep -E "FATAL|ERROR|required" "$log" | tail -5 >&2 || true
fi
sleep 4  # let rviz draw the final markers
mkdir -p "$(dirname "$out")"
import -window root "$out"
echo "screenshot: $out"
exit $status
