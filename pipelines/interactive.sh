#!/usr/bin/env bash
# Pipeline (2): interactive viewing of the real Chess light field (64
# cameras) in a window. Navigation events from the video sink steer the view:
# drag with button 1 to move the eye over the camera plane, the wheel to move
# the focal plane, arrow keys to step the eye, Page_Up/Page_Down (+/-) to move
# it along the normal, r to reset. Needs a display (X11/Wayland).
#
# usage: pipelines/interactive.sh [BLOCK]   (BLOCK default 0,0,8,8)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
mkdir -p "$root/out"
rig="$root/out/interactive-rig.json"
"$build/tools/lf-rig" --input "$root/../shared/data/stanford-chess" --block "${1:-0,0,8,8}" --out "$rig"
if [ -z "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
  echo "interactive.sh: no display; use pipelines/chess64.sh for a video file" >&2
  exit 1
fi
exec "$root/pipelines/lf-pipeline.sh" "$rig" \
  "is-live=true framerate=30/1 width=640 height=480 focal-plane=param:-0.25" \
  "videoconvert ! autovideosink" "is-live=true framerate=30/1"
