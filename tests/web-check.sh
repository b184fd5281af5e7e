#!/usr/bin/env bash
# Browser test of lf-web (issue 10): headless Debian chromium, driven by
# playwright-core (tests/web/web-test.mjs), against lf-web on loopback with the
# real Chess light field: video plays at 640x480, a drag and a click to focus
# change the picture as expected, three browsers steer independently, hostile
# control messages are refused, a browser leaving frees its branch, four
# browsers at once, clean shutdown on SIGINT.
# scripts/test.sh installs chromium and the driver (npm ci in tests/web).
#
# usage: tests/web-check.sh BUILD_DIR SHARED_DATA_DIR
set -euo pipefail
build="$1"; data="$2"
here="$(cd "$(dirname "$0")" && pwd)"
if [ ! -d "$data/stanford-chess" ]; then
  echo "web: $data/stanford-chess is absent (scripts/get-data.sh): skipped"
  exit 77
fi
command -v chromium >/dev/null || { echo "web: chromium is not installed (scripts/test.sh installs it)" >&2; exit 1; }
command -v node >/dev/null || { echo "web: node is not installed (scripts/test.sh installs it)" >&2; exit 1; }
[ -d "$here/web/node_modules/playwright-core" ] ||
  { echo "web: the test driver is missing: (cd tests/web && npm ci) (scripts/test.sh does it)" >&2; exit 1; }
export GST_PLUGIN_PATH="$build/gst" GST_REGISTRY="$build/web-test-registry.bin"
cd "$here/web"
exec node web-test.mjs "$build/tools/lf-web" "$data/stanford-chess"
