#!/usr/bin/env bash
# Pipeline (4): the built-in synthetic dynamic scene (a textured disc moving
# at a known depth over a textured background) seen by a synthetic 6x6 array,
# live (cameras and requests on the pipeline clock at 10 Hz), focused on the
# disc's depth, to a video file (and a window when a display exists).
#
# usage: pipelines/synthetic.sh [OUT.avi] [FRAMES]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
out="${1:-$root/out/synthetic.avi}"; frames="${2:-50}"
mkdir -p "$(dirname "$out")"
rig="$(dirname "$out")/synthetic-rig.json"
# 6x6 cameras, 5 cm apart, 160x120 images; disc at 25 x 5 cm = 1.25 m.
"$build/tools/lf-rig" --synthetic 6x6 --spacing 0.05 --size 160x120 --out "$rig"
sink="videoconvert ! jpegenc ! avimux ! filesink location=$out"
if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
  sink="tee name=vt ! queue ! videoconvert ! autovideosink vt. ! queue ! $sink"
fi
"$root/pipelines/lf-pipeline.sh" "$rig" \
  "is-live=true framerate=10/1 num-buffers=$frames width=640 height=480 position=<0.01,0.02,0> focal-plane=depth:1.25" \
  "$sink" "mode=synthetic is-live=true framerate=10/1"
echo "pipeline (4): $frames frames of the synthetic dynamic scene -> $out"
