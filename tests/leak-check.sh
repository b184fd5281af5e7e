#!/usr/bin/env bash
# Leak check: a short pipeline (4 real cameras, 3 requests, raw and JPEG
# fragments) under valgrind memcheck; fails on any memory error or on memory
# definitely lost.
set -euo pipefail
build="$1"; data="$2"
if [ ! -d "$data/stanford-chess" ]; then  # 77: meson's "skipped"
  echo "SKIP: needs the real data $data/stanford-chess (absent; scripts/get-data.sh fetches it)"
  exit 77
fi
export GST_PLUGIN_PATH="$build/gst" GST_REGISTRY="$(mktemp -u /tmp/lf-leak-registry.XXXXXX)"
rig="$(mktemp /tmp/lf-leak-rig.XXXXXX.json)"
trap 'rm -f "$rig" "$GST_REGISTRY"' EXIT
"$build/tools/lf-rig" --input "$data/stanford-chess" --block 3,3,2,2 --input-scale 0.25 --out "$rig"
gst-inspect-1.0 lightfield > /dev/null  # build the registry outside valgrind
root="$(cd "$(dirname "$0")/.." && pwd)"
# One-time allocations of GLib and GStreamer (named and explained in the file).
supp=(--suppressions="$root/tests/lf-valgrind.supp")
[ -f /usr/share/glib-2.0/valgrind/glib.supp ] && supp+=(--suppressions=/usr/share/glib-2.0/valgrind/glib.supp)
for frag in "encoding=raw" "encoding=jpeg jpeg-quality=80"; do
  desc=$(PRINT=1 "$root/pipelines/lf-pipeline.sh" "$rig" \
    "num-buffers=3 width=64 height=48 focal-plane=param:-0.2" "fakesink" "num-buffers=1" "$frag")
  # shellcheck disable=SC2086
  valgrind --quiet "${supp[@]}" --leak-check=full --errors-for-leak-kinds=definite --show-leak-kinds=definite \
    --error-exitcode=9 gst-launch-1.0 -q $desc
  echo "leak check ($frag): no memory errors, nothing definitely lost"
done
