#!/usr/bin/env bash
# The main job: the ROS demo, dataset_player (stand-in front-end, 10 %
# injected outliers, seed 1) -> agnc_pgo back-end nodelet.
#   usage: demo.sh [--dataset FILE.g2o|FILE.irl] [--refresh-doc]
# The dataset: --dataset (or $AGNC_DEMO_DATASET) if given, and it must exist;
# else Manhattan M3500 from the shared datasets (../shared) when they are
# there; else a 3000-pose grid world with revisits from the repository's own
# seeded generator (scripts/make_scaling_graph.py), written to build/worlds.
#  - with a display ($DISPLAY set): opens rviz (Ctrl-C to stop);
#  - headless: runs under Xvfb with software GL, prints the final status table
#    and saves an rviz screenshot to build/demo.png (--refresh-doc: doc/demo.png,
#    the README's picture).
# Installs missing Debian packages and builds first. The offline replay of the
# same run is build/devel/lib/agnc_pgo/agnc_pgo_replay (see README).
# Environment: AGNC_DEMO_RATE (entries/s, default 120), AGNC_DEMO_PORT (master port;
# default 11391 with a display, a free port headless).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

dataset="${AGNC_DEMO_DATASET:-}"
screenshot="$AGNC_BUILD/demo.png"
while [ $# -gt 0 ]; do
  case "$1" in
    --dataset) dataset="${2:?--dataset needs a file}"; shift 2 ;;
    --refresh-doc) screenshot="$AGNC_ROOT/doc/demo.png"; shift ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "[agnc_pgo] demo.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

shared_m3500="$AGNC_ROOT/../shared/datasets/manhattanOlson3500.g2o"
if [ -n "$dataset" ]; then
  if [ ! -f "$dataset" ]; then
    echo "[agnc_pgo] demo.sh: the requested dataset '$dataset' does not exist" >&2
    exit 1
  fi
  dataset="$(cd "$(dirname "$dataset")" && pwd)/$(basename "$dataset")"
  origin="the requested dataset"
elif [ -f "$shared_m3500" ]; then
  dataset="$(cd "$(dirname "$shared_m3500")" && pwd)/$(basename "$shared_m3500")"
  origin="Manhattan M3500 from the shared datasets"
else
  dataset=""
  origin="no shared datasets beside the repository: a generated 3000-pose grid world (seed 1)"
fi

agnc_install_dependencies
agnc_build

if [ -z "$dataset" ]; then
  /usr/bin/python3 "$AGNC_ROOT/scripts/make_scaling_graph.py" --poses 3000 --seed 1 \
    --out "$AGNC_BUILD/worlds" --name grid2d_3000_seed1 >/dev/null
  dataset="$AGNC_BUILD/worlds/grid2d_3000_seed1.g2o"
fi
echo "[agnc_pgo] demo dataset: $dataset ($origin), 10 % injected outliers, seed 1"

export PATH="/usr/bin:$PATH" PYENV_VERSION=system
source "$AGNC_BUILD/devel/setup.bash"
port="${AGNC_DEMO_PORT:-11391}"
export ROS_MASTER_URI="http://localhost:$port"
args=("dataset:=$dataset" outliers:=10 seed:=1 "rate:=${AGNC_DEMO_RATE:-120}")

if [ -n "${DISPLAY:-}" ]; then
  exec roslaunch -p "$port" agnc_pgo demo.launch rviz:=true "${args[@]}"
fi
"$AGNC_ROOT/scripts/screenshot.sh" "$screenshot" "${args[@]}"
