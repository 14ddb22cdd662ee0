#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/: g2o reader, .irl reader, graph sidecar
# parser) with clang + ASan + UBSan in build/fuzz, writes their seed corpus
# and runs each for SECONDS (default 30). Fails on any crash, sanitizer
# report, leak, timeout or oracle failure; the crashing input is left in
# build/fuzz/artifacts/ and its path printed. The corpus grows in
# build/fuzz/corpus/ from run to run. Long runs: scripts/fuzz.sh 600
set -eo pipefail
AGNC_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FUZZ_BUILD="${AGNC_FUZZ_BUILD:-$AGNC_ROOT/build/fuzz}"
SECONDS_EACH="${1:-30}"
CLANG="${AGNC_CLANG:-clang++-14}"

if ! command -v "$CLANG" >/dev/null; then
  echo "[fuzz] $CLANG not found (scripts/setup.sh installs clang-14 and libclang-rt-14-dev)" >&2
  exit 1
fi
cmake -S "$AGNC_ROOT/fuzz" -B "$FUZZ_BUILD" -DCMAKE_CXX_COMPILER="$CLANG" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$FUZZ_BUILD" -j"$(nproc)" >"$FUZZ_BUILD/build.log" 2>&1 || { tail -30 "$FUZZ_BUILD/build.log"; exit 1; }
"$FUZZ_BUILD/make_seeds" "$FUZZ_BUILD/seeds"
mkdir -p "$FUZZ_BUILD/artifacts"

status=0
for target in g2o irl sidecar; do
  corpus="$FUZZ_BUILD/corpus/$target"
  mkdir -p "$corpus"
  log="$FUZZ_BUILD/fuzz_$target.log"
  if "$FUZZ_BUILD/fuzz_$target" -max_total_time="$SECONDS_EACH" -max_len=8192 -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$FUZZ_BUILD/artifacts/${target}-" "$corpus" "$FUZZ_BUILD/seeds/$target" \
      >"$log" 2>&1; then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    echo "[fuzz] $target: ${SECONDS_EACH} s, ${runs:-?} inputs, no finding (corpus $(ls "$corpus" | wc -l) files)"
  else
    echo "[fuzz] $target: FAILED (log: $log)" >&2
    grep -E "ERROR|SUMMARY|oracle failed|artifact|Test unit written" "$log" | head -20 >&2
    status=1
  fi
done
exit $status
