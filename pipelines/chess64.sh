#!/usr/bin/env bash
# Pipeline (1): all 64 cameras of an 8x8 block of the real Stanford "Chess"
# light field, a camera path (an orbit with a dolly through the camera
# plane), 640x480, to a video file; also to a window when a display exists.
#
# usage: pipelines/chess64.sh [OUT.avi] [FRAMES]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
out="${1:-$root/out/chess64.avi}"; frames="${2:-120}"
mkdir -p "$(dirname "$out")"
rig="$(dirname "$out")/chess64-rig.json"
"$build/tools/lf-rig" --input "$root/../shared/data/stanford-chess" --block 0,0,8,8 --out "$rig"
file_sink="videoconvert ! jpegenc quality=90 ! avimux ! filesink location=$out"
if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
  sink="tee name=vt ! queue ! videoconvert ! autovideosink vt. ! queue ! $file_sink"
else
  sink="$file_sink"
fi
"$root/pipelines/lf-pipeline.sh" "$rig" \
  "orbit=0.6 dolly=15 path-frames=$frames num-buffers=$frames focal-plane=param:-0.25 width=640 height=480" \
  "$sink"
echo "pipeline (1): $frames frames from 64 cameras -> $out"
