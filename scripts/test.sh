#!/usr/bin/env bash
# Sets everything up (scripts/setup.sh) and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
# The build directory: $LF_BUILD_DIR (default ./build).
export LF_BUILD_DIR="${LF_BUILD_DIR:-$PWD/build}"
build="$LF_BUILD_DIR"
./scripts/setup.sh
# The browser test's browser and driver (tests/web-check.sh): Debian's
# chromium, Node.js where the machine has none, playwright-core from npm.
./scripts/install-packages.sh chromium
# The format check (tests/format-check.sh).
command -v clang-format > /dev/null || ./scripts/install-packages.sh clang-format
command -v node >/dev/null && command -v npm >/dev/null || ./scripts/install-packages.sh nodejs npm
# A hung command's thread backtraces (tests/backtraces.sh, used by tests/docs-check.sh).
command -v gdb > /dev/null || ./scripts/install-packages.sh gdb
[ -d tests/web/node_modules/playwright-core ] || (cd tests/web && npm ci --no-audit --no-fund --loglevel=error)
# The real data is read in place from ../shared/data; without it (a fresh
# clone) the tests that need it are skipped and named at the end.
have_data=0; [ -d ../shared/data ] && have_data=1
[ "$have_data" = 1 ] || echo "test: ../shared/data is absent: the tests that need the real data will be skipped (scripts/get-data.sh fetches it)" >&2
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
# The fragment kernels against OpenCV's warpPerspective on this machine,
# with its CPU (lf-bench's speed table, about 10 s): a timing on a shared
# machine, so printed for the record, not asserted (docs/results.md,
# Kernels, has the full table).
if [ "$have_data" = 1 ]; then
  echo "kernels on this machine (lf-bench --sizes 640x480 --skip-quality --skip-bandwidth):"
  "$build/tools/lf-bench" --input ../shared/data/stanford-chess --sizes 640x480 --skip-quality \
    --skip-bandwidth 2>/dev/null | grep -E '^CPU:|^ours|taps: by' || echo "  (lf-bench failed)"
fi
# One closing line with GoogleTest's counts over all test programs (both
# builds) and the fuzz harnesses.
passed=0; failed=0; skipped=()
for f in "$build"/gtest-xml/*.xml ${LF_SAN_BUILD_DIR:+"$LF_SAN_BUILD_DIR"/gtest-xml/*.xml}; do
  [ -f "$f" ] || continue
  t=$(grep -m1 -o 'tests="[0-9]*"' "$f" | grep -o '[0-9]*')
  fl=$(grep -m1 -o 'failures="[0-9]*"' "$f" | grep -o '[0-9]*')
  er=$(grep -m1 -o 'errors="[0-9]*"' "$f" | grep -o '[0-9]*')
  mapfile -t sk < <(sed -n 's/.*<testcase name="\([^"]*\)".*result="skipped".*classname="\([^"]*\)".*/\2.\1/p' "$f")
  passed=$((passed + t - fl - er - ${#sk[@]})); failed=$((failed + fl + er))
  skipped+=("${sk[@]/#/$(basename "$f" .xml | sed 's/_[0-9]*$//'): }")
done
# Whole test programs that skipped themselves (exit 77: meson's SKIP).
for log in "$build/meson-logs/testlog.json"; do
  [ -f "$log" ] || continue
  mapfile -t sk < <(grep '"result": "SKIP"' "$log" | sed 's/.*"name": "\([^"]*\)".*/\1/')
  skipped+=("${sk[@]/#/meson test: }")
done
if [ "${#skipped[@]}" -gt 0 ]; then
  echo "skipped ${#skipped[@]} (they need the real data in ../shared/data):"
  printf '  %s\n' "${skipped[@]}"
  if [ "$have_data" = 1 ]; then
    echo "test: ../shared/data is present, so nothing may be skipped" >&2
    status=1; failed=$((failed + ${#skipped[@]}))
  fi
fi
if [ -n "${LF_SAN_BUILD_DIR:-}" ] && [ -f "$LF_SAN_BUILD_DIR/fuzz-report.md" ]; then
  passed=$((passed + $(grep -c '| ok |' "$LF_SAN_BUILD_DIR/fuzz-report.md" || true)))
  failed=$((failed + $(grep -c 'FAILED' "$LF_SAN_BUILD_DIR/fuzz-report.md" || true)))
fi
if [ "$status" -ne 0 ] && [ "$failed" -eq 0 ]; then failed=1; fi
echo "tests: ${passed} passed, ${failed} failed, ${#skipped[@]} skipped"
exit "$status"
