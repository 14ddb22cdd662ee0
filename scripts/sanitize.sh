#!/usr/bin/env bash
# Sanitizer runs (called by .ci/run after scripts/test.sh):
#  1. ASan + UBSan build in build/asan of what the tests run (the `tests`
#     target: core, nodelet, tools, test binaries; not the rviz plugin, which
#     no test loads): every gtest (leak detection on) and every rostest (the
#     nodelet manager, a system binary, gets libasan preloaded to load the
#     instrumented plugin). The Python script tests are left out: nothing
#     instrumented runs in them.
#  2. TSan build of the nodelet in build/tsan: the end-to-end rostest, with
#     the manager running under libtsan.
# Fails on any test failure and on any sanitizer report (left in
# build/{asan,tsan}/reports/). Prints the time of each phase.
# Usage: scripts/sanitize.sh [asan|tsan|all]
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
WHICH="${1:-all}"
agnc_install_dependencies
export PATH="/usr/bin:$PATH" PYENV_VERSION=system

configure_and_build() {  # dir flags targets...
  local dir="$1" flags="$2"
  shift 2
  mkdir -p "$dir/ros_home"
  cmake -S "$AGNC_ROOT" -B "$dir" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_CXX_FLAGS_RELEASE="-O1 -g1 -DNDEBUG" -DCMAKE_CXX_FLAGS="$flags -fno-omit-frame-pointer" \
    -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" \
    -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
  if ! cmake --build "$dir" -j"$(nproc)" --target "$@" >"$dir/build.log" 2>&1; then
    grep -E -A5 "error|Error" "$dir/build.log" | head -40
    echo "[sanitize] build in $dir failed; log: $dir/build.log" >&2
    return 1
  fi
}

# Sanitizer reports as files: any file means failure.
check_reports() {  # dir label
  local reports
  reports=$(ls "$1/reports" 2>/dev/null | wc -l)
  if [ "$reports" -ne 0 ]; then
    echo "[sanitize] $2: $reports sanitizer report(s) in $1/reports:" >&2
    head -30 "$1"/reports/* >&2
    return 1
  fi
  echo "[sanitize] $2: no sanitizer report"
}

run_rostests() {  # dir tests...
  local dir="$1"
  shift
  local status=0
  # The rostests' generated world (CMake passes it to ctest's rostests the same way).
  export AGNC_PGO_TEST_WORLD_DIR="$dir/test_worlds"
  for t in "$@"; do
    if timeout 600 rostest agnc_pgo "$t" >"$dir/reports_log_$t.log" 2>&1; then
      echo "[sanitize] rostest $t: passed"
    else
      echo "[sanitize] rostest $t: FAILED (log $dir/reports_log_$t.log)" >&2
      status=1
    fi
  done
  return $status
}

status=0
if [ "$WHICH" = all ] || [ "$WHICH" = asan ]; then
  dir="$AGNC_ROOT/build/asan"
  start=$SECONDS
  configure_and_build "$dir" "-fsanitize=address,undefined -fno-sanitize-recover=undefined" tests
  echo "[sanitize] asan: build $((SECONDS - start)) s"
  rm -rf "$dir/reports" "$dir/test_results" && mkdir -p "$dir/reports"
  (
    export ROS_HOME="$dir/ros_home"
    source "$dir/devel/setup.bash"
    export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:log_path=$dir/reports/ubsan"
    export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:log_path=$dir/reports/asan"
    start=$SECONDS
    ctest --test-dir "$dir" -E "rostest|install_test|pytest" --output-on-failure --timeout 600 >"$dir/ctest.log" 2>&1 \
      && echo "[sanitize] asan gtests: $(grep -E 'tests passed' "$dir/ctest.log"), $((SECONDS - start)) s" \
      || { echo "[sanitize] asan gtests FAILED (log $dir/ctest.log)" >&2; exit 1; }
    # ROS keeps process-lifetime allocations (singletons) until exit: no leak check in the rostests.
    export ASAN_OPTIONS="detect_leaks=0:halt_on_error=1:log_path=$dir/reports/asan"
    export AGNC_PGO_MANAGER_PREFIX="env LD_PRELOAD=$(gcc -print-file-name=libasan.so) ASAN_OPTIONS=$ASAN_OPTIONS"
    start=$SECONDS
    run_rostests "$dir" $(cd "$AGNC_ROOT/test/ros" && ls *.test) || exit 1
    echo "[sanitize] asan rostests: $((SECONDS - start)) s"
  ) || status=1
  check_reports "$dir" asan || status=1
fi
if [ "$WHICH" = all ] || [ "$WHICH" = tsan ]; then
  dir="$AGNC_ROOT/build/tsan"
  # gcc's TSan runtime symbolizes only with an external symbolizer (clang-14 has one).
  symbolizer=""
  [ -x /usr/lib/llvm-14/bin/llvm-symbolizer ] && symbolizer=":external_symbolizer_path=/usr/lib/llvm-14/bin/llvm-symbolizer"
  start=$SECONDS
  configure_and_build "$dir" "-fsanitize=thread" agnc_pgo_ros dataset_player backend_node agnc_pgo_generate_messages
  echo "[sanitize] tsan: build $((SECONDS - start)) s"
  rm -rf "$dir/reports" && mkdir -p "$dir/reports"
  (
    export ROS_HOME="$dir/ros_home"
    source "$dir/devel/setup.bash"
    export TSAN_OPTIONS="halt_on_error=0:second_deadlock_stack=1:log_path=$dir/reports/tsan:suppressions=$AGNC_ROOT/scripts/tsan_suppressions.txt:print_suppressions=0$symbolizer"
    export AGNC_PGO_MANAGER_PREFIX="env LD_PRELOAD=$(gcc -print-file-name=libtsan.so) TSAN_OPTIONS=$TSAN_OPTIONS"
    start=$SECONDS
    run_rostests "$dir" end_to_end.test || exit 1
    echo "[sanitize] tsan rostest: $((SECONDS - start)) s"
  ) || status=1
  check_reports "$dir" tsan || status=1
fi
exit $status
