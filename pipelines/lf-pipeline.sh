#!/usr/bin/env bash
# Builds (and runs) a single-machine gst-launch-1.0 pipeline of the
# finite-viewpoints system (Yang et al. 2002, Figure 2): one lfcamsrc +
# lffragment per camera, one lfviewrequest broadcasting requests through a
# tee, one lfcompositor, any sink.
#
# usage: lf-pipeline.sh RIG.json "REQUEST PROPERTIES" "SINK DESCRIPTION" [CAMSRC PROPERTIES] [FRAGMENT PROPERTIES]
#   RIG.json          rig file (tools/lf-rig makes one from a dataset)
#   REQUEST ...       lfviewrequest properties, e.g. "orbit=0.6 num-buffers=90 focal-plane=param:-0.2"
#   SINK ...          e.g. "videoconvert ! jpegenc ! avimux ! filesink location=out.avi"
#   CAMSRC ...        lfcamsrc properties (default: num-buffers=1, a still)
#   FRAGMENT ...      lffragment properties, e.g. "encoding=jpeg jpeg-quality=90"
# COMPOSITOR: lfcompositor properties (default "latency=50000000": in live
#   pipelines a request is composited with what arrived 50 ms after its time).
# Set PRINT=1 to print the description instead of running it.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
rig="$1"; request="$2"; sink="$3"; camsrc="${4:-num-buffers=1}"; fragment="${5:-}"
export GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
ids=$("$build/tools/lf-rig" --input "$rig" --ids)
desc="lfviewrequest rig=$rig $request ! tee name=t  lfcompositor name=comp rig=$rig ${COMPOSITOR:-latency=50000000} ! $sink"
i=0
for id in $ids; do
  desc+="  lfcamsrc rig=$rig camera-id=$id $camsrc ! f$i.sink"
  desc+="  t. ! queue max-size-buffers=4 ! lffragment name=f$i rig=$rig camera-id=$id $fragment ! comp.sink_$i"
  i=$((i + 1))
done
if [ "${PRINT:-0}" = 1 ]; then echo "$desc"; exit 0; fi
# shellcheck disable=SC2086
exec gst-launch-1.0 -q $desc
