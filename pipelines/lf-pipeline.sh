#!/usr/bin/env bash
# Runs a single-machine gst-launch-1.0 pipeline of the finite-viewpoints
# system (Yang et al. 2002, Figure 2): lfviewrequest ! lfarray ! SINK, where
# the lfarray bin builds one lfcamsrc + lffragment per camera of the rig and
# the lfcompositor (one place builds the graph: gst/lfcamerahost.cpp).
#
# usage: lf-pipeline.sh RIG.json "REQUEST PROPERTIES" "SINK DESCRIPTION" [CAMSRC PROPERTIES] [FRAGMENT PROPERTIES]
#   RIG.json          rig file (tools/lf-rig makes one from a dataset)
#   REQUEST ...       lfviewrequest properties, e.g. "orbit=0.6 num-buffers=90 focal-plane=param:-0.2"
#   SINK ...          e.g. "videoconvert ! jpegenc ! avimux ! filesink location=out.avi"
#   CAMSRC ...        camera properties of lfarray (mode, is-live, framerate,
#                     phase, num-buffers; default: num-buffers=1, a still)
#   FRAGMENT ...      fragment properties of lfarray, e.g. "encoding=jpeg jpeg-quality=90"
# COMPOSITOR: compositor properties of lfarray (default "latency=50000000":
#   in live pipelines a request is composited with what arrived 50 ms after
#   its time; also viewer-id, stereo, width, height).
# Set PRINT=1 to print the description instead of running it.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
rig="$1"; request="$2"; sink="$3"; camsrc="${4:-num-buffers=1}"; fragment="${5:-}"
export GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
desc="lfviewrequest rig=$rig $request ! lfarray rig=$rig $camsrc $fragment"
desc+=" ${COMPOSITOR:-latency=50000000} ! $sink"
if [ "${PRINT:-0}" = 1 ]; then echo "$desc"; exit 0; fi
# shellcheck disable=SC2086
exec gst-launch-1.0 -q $desc
