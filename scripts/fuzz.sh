#!/usr/bin/env bash
# Builds the libFuzzer harnesses (tests/fuzz) with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer, seeds them from valid messages and runs each
# for SECONDS (default 60). The corpus grows in BUILD/corpus between runs; a
# crash, a sanitizer report or running out of memory fails the script (the
# reproducer is left in BUILD/artifacts). Long runs: scripts/fuzz.sh 3600.
# usage: scripts/fuzz.sh [SECONDS] [BUILD_DIR (default build-san)]
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-60}"
build="${2:-${LF_SAN_BUILD_DIR:-$PWD/build-san}}"
./scripts/setup-san.sh "$build" > /dev/null
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
seeds="$build/seeds"
rm -rf "$seeds"
"$build/tests/fuzz/make_seeds" "$seeds" > /dev/null
mkdir -p "$build/artifacts"
status=0
report="$build/fuzz-report.md"
printf '| harness | seconds | executions | exec/s | corpus | result |\n|---|---|---|---|---|---|\n' | tee "$report"
for h in fragment request rig bal; do
  corpus="$build/corpus/$h"
  mkdir -p "$corpus"
  log="$build/fuzz-$h.log"
  rc=0
  "$build/tests/fuzz/fuzz_$h" -max_total_time="$secs" -rss_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$build/artifacts/$h-" "$corpus" "$seeds/$h" \
    > "$log" 2>&1 || rc=$?
  execs=$(awk '/stat::number_of_executed_units/ {print $2}' "$log" | tail -1)
  rate=$(awk '/stat::average_exec_per_sec/ {print $2}' "$log" | tail -1)
  files=$(ls "$corpus" | wc -l)
  result=ok
  if [ "$rc" -ne 0 ]; then
    result="FAILED (exit $rc, see $log)"; status=1
    tail -40 "$log" >&2
  fi
  echo "| $h | $secs | ${execs:-0} | ${rate:-0} | $files | $result |" | tee -a "$report"
done
exit "$status"
