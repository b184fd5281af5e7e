#!/usr/bin/env bash
# lf-web's viewer lifetime and admission (tests/web/lifetime-test.mjs), with
# no browser: connect/close cycles leave threads, fds and memory at the idle
# level; silent connections lose their slots at the handshake deadline; a
# foreign Origin and a missing --token are refused.
#
# usage: tests/web-lifetime-check.sh BUILD_DIR SHARED_DATA_DIR [CYCLES]
set -euo pipefail
build="$1"; data="$2"; cycles="${3:-1000}"
here="$(cd "$(dirname "$0")" && pwd)"
if [ ! -d "$data/stanford-chess" ]; then
  echo "web-lifetime: $data/stanford-chess is absent (scripts/get-data.sh): skipped"
  exit 77
fi
command -v node >/dev/null || { echo "web-lifetime: node is not installed (scripts/test.sh installs it)" >&2; exit 1; }
export GST_PLUGIN_PATH="$build/gst" GST_REGISTRY="$build/web-lifetime-registry.bin"
cd "$here/web"
exec node lifetime-test.mjs "$build/tools/lf-web" "$data/stanford-chess" --cycles "$cycles"
