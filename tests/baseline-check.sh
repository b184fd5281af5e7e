#!/usr/bin/env bash
# tools/lf-baseline on a small synthetic rig (2x2 cameras, 160x120, sensor
# noise): it runs end to end (every camera answers every request, or it
# fails), the JPEG's PSNR of the camera images is that of a good JPEG (a
# colour-range mix-up between encoder and decoder read as about 30 dB), and
# H.264 reaches the JPEG's PSNR within its quantiser sweep in fewer bytes
# than JPEG (inter-frame prediction; with fresh noise in every frame it
# still wins on a static background).
# usage: baseline-check.sh BUILD_DIR
set -euo pipefail
build="$(cd "$1" && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
export GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
"$build/tools/lf-rig" --synthetic 2x2 --size 160x120 --out "$work/rig.json"
"$build/tools/lf-baseline" --rig "$work/rig.json" --frames 15 --sample 2 --qp 11,18,26,34 \
  --size 160x120 > "$work/out.txt"
cat "$work/out.txt"
awk '/^## summary/{s=1; next} s{v[$1]=$2} END{
  ok = 1
  if (!(v["fragment-bytes"] > 0)) { print "FAIL: no fragment bytes"; ok = 0 }
  if (!(v["jpeg-psnr"] >= 38 && v["jpeg-psnr"] <= 60)) { print "FAIL: JPEG PSNR " v["jpeg-psnr"] " outside 38..60 dB"; ok = 0 }
  if (!(v["h264-bytes"] > 0)) { print "FAIL: H.264 did not reach the JPEG PSNR within the sweep"; ok = 0 }
  else if (!(v["h264-bytes"] < v["jpeg-bytes"])) { print "FAIL: H.264 bytes " v["h264-bytes"] " not below JPEG " v["jpeg-bytes"]; ok = 0 }
  if (ok) print "ok: JPEG PSNR " v["jpeg-psnr"] " dB; bytes per frame: fragments " v["fragment-bytes"] ", JPEG " v["jpeg-bytes"] ", H.264 " v["h264-bytes"]
  exit !ok }' "$work/out.txt"
