#!/usr/bin/env bash
# Sets everything up (scripts/setup.sh) and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
# The build directory: $LF_BUILD_DIR (default ./build).
export LF_BUILD_DIR="${LF_BUILD_DIR:-$PWD/build}"
build="$LF_BUILD_DIR"
./scripts/setup.sh
if [ ! -d ../shared/data ]; then
  echo "test: ../shared/data is missing (the real-data tests read it in place)" >&2
  exit 1
fi
rm -rf "$build/gtest-xml"
status=0
GTEST_OUTPUT=xml:"$build/gtest-xml/" meson test -C "$build" --print-errorlogs || status=$?
# The sanitizer run (ASan + UBSan build of the in-process tests, and a short
# run of each fuzz harness); LF_SANITIZERS=0 skips it.
if [ "${LF_SANITIZERS:-1}" != 0 ]; then
  export LF_SAN_BUILD_DIR="${LF_SAN_BUILD_DIR:-$PWD/build-san}"
  rm -rf "$LF_SAN_BUILD_DIR/gtest-xml" "$LF_SAN_BUILD_DIR/fuzz-report.md"
  ./scripts/test-san.sh "${LF_FUZZ_SECONDS:-60}" || status=$?
fi
# One closing line with GoogleTest's counts over all test programs (both
# builds) and the fuzz harnesses.
passed=0; failed=0
for f in "$build"/gtest-xml/*.xml ${LF_SAN_BUILD_DIR:+"$LF_SAN_BUILD_DIR"/gtest-xml/*.xml}; do
  [ -f "$f" ] || continue
  t=$(grep -m1 -o 'tests="[0-9]*"' "$f" | grep -o '[0-9]*')
  fl=$(grep -m1 -o 'failures="[0-9]*"' "$f" | grep -o '[0-9]*')
  er=$(grep -m1 -o 'errors="[0-9]*"' "$f" | grep -o '[0-9]*')
  passed=$((passed + t - fl - er)); failed=$((failed + fl + er))
done
if [ -n "${LF_SAN_BUILD_DIR:-}" ] && [ -f "$LF_SAN_BUILD_DIR/fuzz-report.md" ]; then
  passed=$((passed + $(grep -c '| ok |' "$LF_SAN_BUILD_DIR/fuzz-report.md" || true)))
  failed=$((failed + $(grep -c 'FAILED' "$LF_SAN_BUILD_DIR/fuzz-report.md" || true)))
fi
if [ "$status" -ne 0 ] && [ "$failed" -eq 0 ]; then failed=1; fi
echo "tests: ${passed} passed, ${failed} failed"
exit "$status"
