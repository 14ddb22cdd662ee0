#!/usr/bin/env bash
# The README's picture of the right-click overrides (doc/menu.png): runs the
# demo on the rostests' small world (400 poses, 10 % injected outliers, seed
# 1) with the interactive markers (menu:=true), waits until the back-end has
# settled, opens rviz with a top-down view of the whole graph, right-clicks
# the marker of a rejected loop closure (xdotool) and saves the screen with
# its context menu open, cropped and scaled down.
#   usage: menu_screenshot.sh [OUT.png]   (default build/menu.png;
#          scripts/menu_screenshot.sh doc/menu.png refreshes the README's)
# Without $DISPLAY it re-runs itself under Xvfb (software GL). Installs
# missing Debian packages and builds first. AGNC_DEMO_PORT: master port
# (default: a free one).
set -eo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [ -z "${DISPLAY:-}" ]; then
  exec xvfb-run -a -s "-screen 0 1280x800x24" "$0" "$@"
fi
source "$here/setup.sh"
out="${1:-$AGNC_BUILD/menu.png}"
agnc_install_dependencies
agnc_build

export LIBGL_ALWAYS_SOFTWARE=1 PATH="/usr/bin:$PATH" PYENV_VERSION=system
source "$AGNC_BUILD/devel/setup.bash"
port="${AGNC_DEMO_PORT:-$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')}"
export ROS_MASTER_URI="http://localhost:$port"
work="$AGNC_BUILD/menu_screenshot"
mkdir -p "$work"
/usr/bin/python3 "$here/make_scaling_graph.py" --poses 400 --seed 1 --out "$work" --name grid2d_400_seed1 >/dev/null

roslaunch -p "$port" agnc_pgo demo.launch dataset:="$work/grid2d_400_seed1.g2o" outliers:=10 seed:=1 \
  rate:=300 menu:=true output:=log >"$work/roslaunch.log" 2>&1 &
launch_pid=$!
rviz_pid=""
cleanup() {
  [ -n "$rviz_pid" ] && kill -INT "$rviz_pid" 2>/dev/null && wait "$rviz_pid" 2>/dev/null
  kill -INT "$launch_pid" 2>/dev/null || true
  wait "$launch_pid" 2>/dev/null || true
}
trap cleanup EXIT

/usr/bin/python3 "$here/ros_status.py" --timeout 120
# The 3-D view to the right of the panel: 1280 x 800 screen, rviz's default
# layout from rviz/agnc_pgo.rviz.
read -r index x y scale cx cy < <(/usr/bin/python3 "$here/menu_view.py" \
  --rviz-in "$AGNC_ROOT/rviz/agnc_pgo.rviz" --rviz-out "$work/menu.rviz" --width 720 --height 640)
echo "[agnc_pgo] right-clicking loop closure $index (marker at $x, $y in map)"
rviz -d "$work/menu.rviz" >"$work/rviz.log" 2>&1 &
rviz_pid=$!
xdotool search --sync --onlyvisible --name "RViz" >/dev/null
sleep 12  # software GL: the first frames, the markers and the panel's table

# The render window: the largest child window of rviz's that is not the
# whole window (Ogre draws into a native child).
read -r left top width height < <(xwininfo -root -tree | /usr/bin/python3 -c '
import re, sys
best = None
for line in sys.stdin:
    m = re.search(r"(\d+)x(\d+)\+(-?\d+)\+(-?\d+)\s+\+(-?\d+)\+(-?\d+)\s*$", line)
    if not m:
        continue
    w, h, ax, ay = int(m.group(1)), int(m.group(2)), int(m.group(5)), int(m.group(6))
    if w >= 1280 or w < 300 or h < 300:
        continue
    if best is None or w * h > best[0] * best[1]:
        best = (w, h, ax, ay)
print(best[2], best[3], best[0], best[1])')
px=$(/usr/bin/python3 -c "print(round($left + $width / 2 + $scale * ($x - $cx)))")
py=$(/usr/bin/python3 -c "print(round($top + $height / 2 - $scale * ($y - $cy)))")
echo "[agnc_pgo] 3-D view ${width}x${height}+${left}+${top}; marker at pixel $px,$py"
xdotool mousemove "$px" "$py"
sleep 1
xdotool click 3
sleep 3
import -window root "$work/screen.png"
mkdir -p "$(dirname "$out")"
convert "$work/screen.png" -resize 75% -colors 128 -strip "$out"
echo "screenshot: $out ($(stat -c %s "$out") bytes)"
