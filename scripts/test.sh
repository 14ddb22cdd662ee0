#!/usr/bin/env bash
# Builds agnc_pgo and runs every test (gtest unit tests and rostests).
# Installs missing Debian packages first. Exits non-zero if any test fails or
# if no test ran.
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

agnc_install_dependencies
agnc_build
agnc_build --target tests

# ROS tools are Python programs of Debian's python3.
export PATH="/usr/bin:$PATH" PYENV_VERSION=system
source "$AGNC_BUILD/devel/setup.bash"

rm -rf "$AGNC_BUILD/test_results"
set +e
ctest --test-dir "$AGNC_BUILD" --output-on-failure --timeout 600
ctest_status=$?
set -e

# The catkin results summary counts every gtest/rostest case that ran.
summary=$(catkin_test_results "$AGNC_BUILD/test_results" 2>&1 | tail -1)
echo "$summary"
tests=$(echo "$summary" | sed -n 's/^Summary: \([0-9]*\) tests.*/\1/p')
errors=$(echo "$summary" | sed -n 's/.* \([0-9]*\) errors.*/\1/p')
failures=$(echo "$summary" | sed -n 's/.* \([0-9]*\) failures.*/\1/p')
if [ -z "$tests" ] || [ "$tests" -eq 0 ]; then
  echo "[agnc_pgo] no test ran" >&2
  exit 1
fi

# Robustness probes (README "Reliability"): SIGKILL during ~save_graph, and
# bounded fuzzing of the file readers (AGNC_FUZZ_SECONDS each, default 30).
set +e
python3 "$AGNC_ROOT/scripts/durability_test.py" --trials 24 >"$AGNC_BUILD/durability.log" 2>&1
durability_status=$?
grep '^\[durability\] [0-9]* trials' "$AGNC_BUILD/durability.log" || tail -20 "$AGNC_BUILD/durability.log"
bash "$AGNC_ROOT/scripts/fuzz.sh" "${AGNC_FUZZ_SECONDS:-30}"
fuzz_status=$?
set -e
# Counted as two more tests in the summary line.
tests=$((tests + 2))
for probe_status in "$durability_status" "$fuzz_status"; do
  [ "$probe_status" -eq 0 ] || failures=$(( ${failures:-0} + 1 ))
done

passed=$((tests - ${errors:-0} - ${failures:-0}))
echo "${passed} passed, $(( ${errors:-0} + ${failures:-0} )) failed"
if [ "$ctest_status" -ne 0 ] || [ "${errors:-0}" -ne 0 ] || [ "${failures:-0}" -ne 0 ]; then
  exit 1
fi
