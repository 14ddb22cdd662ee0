#!/usr/bin/env bash
# Benchmarks agnc_pgo (../shared/ALGORITHM.md §5): installs missing Debian
# packages, builds the package in ./build, then runs scripts/benchmark.py with
# the given arguments (see scripts/benchmark.py --help), which writes
# doc/benchmark.md and its plots. Run it on a quiet machine.
#   scripts/benchmark.sh --quick            # CSAIL and Intel logs only
#   scripts/benchmark.sh --seeds 1,2,3 --repeat 3
#   scripts/benchmark.sh --peers gnc,isam2   # GTSAM beside agnc_pgo (its own venv)
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

# perf stat counts each run's instructions (the drift-free measure of work);
# python3-venv makes the venv of the GTSAM peers (--peers).
AGNC_PACKAGES+=(linux-perf python3-venv)
agnc_install_dependencies
agnc_build

# Recorded in doc/benchmark.md as the command that reproduces the run.
AGNC_BENCHMARK_COMMAND="scripts/benchmark.sh"
if [ $# -gt 0 ]; then AGNC_BENCHMARK_COMMAND+="$(printf ' %q' "$@")"; fi
export AGNC_BENCHMARK_COMMAND
# The tool just built (a --tool among the arguments overrides it).
exec /usr/bin/python3 "$AGNC_ROOT/scripts/benchmark.py" --tool "$AGNC_BUILD/devel/lib/agnc_pgo/agnc_pgo_replay" "$@"
