#!/usr/bin/env bash
# Pipeline (3): a stereo pair (paper Figure 11) from the real Chess light
# field: left and right eyes 6 units apart, side by side (left | right, for
# parallel viewing or a head-mounted display), along an orbit, to a video file.
#
# usage: pipelines/stereo.sh [OUT.avi] [FRAMES]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
out="${1:-$root/out/chess-stereo.avi}"; frames="${2:-90}"
mkdir -p "$(dirname "$out")"
rig="$(dirname "$out")/stereo-rig.json"
"$build/tools/lf-rig" --input "$root/../shared/data/stanford-chess" --block 0,0,8,8 --out "$rig"
desc=$(PRINT=1 COMPOSITOR="stereo=true viewer-id=0" "$root/pipelines/lf-pipeline.sh" "$rig" \
  "orbit=0.5 path-frames=$frames num-buffers=$frames stereo-baseline=6 width=480 height=360 focal-plane=param:-0.25" \
  "videoconvert ! jpegenc quality=90 ! avimux ! filesink location=$out")
# shellcheck disable=SC2086
GST_PLUGIN_PATH="$build/gst" gst-launch-1.0 -q $desc
echo "pipeline (3): $frames stereo frames (960x360, left | right) -> $out"
