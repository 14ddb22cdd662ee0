#!/usr/bin/env bash
# The main job: replays Manhattan M3500 with 10 % injected outliers (seed 1)
# through the adaptive GNC engine and prints the result table.
# Installs missing Debian packages and builds first.
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

agnc_install_dependencies
agnc_build

SHARED="$AGNC_ROOT/../shared/datasets"
"$AGNC_BUILD/devel/lib/agnc_pgo/agnc_pgo_replay" \
  --input "$SHARED/manhattanOlson3500.g2o" \
  --ground-truth "$SHARED/manhattanOlson3500_gt.g2o" \
  --outliers 10 --seed 1 --schedule agnc \
  --output "$AGNC_BUILD/demo"
echo "outputs: $AGNC_BUILD/demo (metrics.json, estimate.g2o, trajectory.tum, loop_closures.csv)"
