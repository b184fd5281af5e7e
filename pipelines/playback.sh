#!/usr/bin/env bash
# Plays back a recording made by pipelines/record.sh through the same
# pipeline, each camera on its recorded capture schedule, with the same view
# requests: DIR/playback.avi equals DIR/live.avi frame for frame (from a
# lossless recording; up to the final JPEG encoding of the .avi, which is
# deterministic). Both scripts give the compositor a 1 s deadline, so every
# frame is complete; a live run that composites without late fragments (an
# overloaded machine at the default one-period deadline) differs there.
#
# usage: pipelines/playback.sh RIG.json DIR [FRAMES]   (env FPS, VIEW as for record.sh)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"
rig="$1"; dir="$2"; frames="${3:-50}"
fps="${FPS:-10}"; view="${VIEW:-width=640 height=480 orbit=0.5 path-frames=$frames}"
export GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
# shellcheck disable=SC2086
gst-launch-1.0 -q -e lfviewrequest rig="$rig" is-live=true framerate=$fps/1 num-buffers=$frames $view ! \
  lfarray rig="$rig" latency=1000000000 playback="$dir/cam%02d.mkv" ! \
  videoconvert ! jpegenc quality=95 ! avimux ! filesink location="$dir/playback.avi"
echo "playback: $dir/camNN.mkv -> $dir/playback.avi"
