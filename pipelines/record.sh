#!/usr/bin/env bash
# Records every camera of a live light field array: each camera's frames and
# capture times to DIR/camNN.mkv (GStreamer's matroskamux, nanosecond
# timecodes), while the live view is composited to DIR/live.avi. Play it
# back with pipelines/playback.sh: for the same requests the output equals
# the live run's (bit-identical with QUALITY=0, the default: lossless raw RGB;
# 1..100: JPEG at that quality, about a quarter of the size at 90).
#
# usage: pipelines/record.sh RIG.json DIR [FRAMES]
# env:   MODE (lfcamsrc mode: synthetic (default), dataset, file, v4l2),
#        FPS (default 10), QUALITY (default 0), VIEW (lfviewrequest
#        properties, default "width=640 height=480 orbit=0.5 path-frames=FRAMES")
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"
rig="$1"; dir="$2"; frames="${3:-50}"
fps="${FPS:-10}"; view="${VIEW:-width=640 height=480 orbit=0.5 path-frames=$frames}"
mkdir -p "$dir"
export GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
# The cameras run 5 frames longer than the requests so that every request
# finds its frame; then all streams end and the files are complete.
# shellcheck disable=SC2086
gst-launch-1.0 -q -e lfviewrequest rig="$rig" is-live=true framerate=$fps/1 num-buffers=$frames $view ! \
  lfarray rig="$rig" latency=1000000000 mode="${MODE:-synthetic}" is-live=true framerate=$fps/1 num-buffers=$((frames + 5)) \
    record="$dir/cam%02d.mkv" record-quality="${QUALITY:-0}" ! \
  videoconvert ! jpegenc quality=95 ! avimux ! filesink location="$dir/live.avi"
echo "record: $(ls "$dir"/cam*.mkv | wc -l) cameras -> $dir/camNN.mkv ($(du -sh "$dir" | cut -f1)); live view -> $dir/live.avi"
