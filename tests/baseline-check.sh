#!/usr/bin/env bash
# tools/lf-baseline on a small rig (a 2x4 block of the Chess cameras at a
# fifth of their size, 280x160; the synthetic scene with sensor noise seen
# through them, 160x120 views): it runs end to end (every camera answers
# every request, or it fails), the JPEG's PSNR of the camera images is
# that of a good JPEG (a colour-range mix-up between encoder and decoder
# read as about 30 dB), H.264 reaches the JPEG's PSNR within its quantiser
# sweep in fewer bytes than JPEG (inter-frame prediction; with fresh noise
# in every frame it still wins on a static background), and partial sums
# of two hosts of 2x2 cameras take fewer bytes than per-camera fragments
# and composite the Chess images no more than 2.5 dB below per-camera JPEG
# fragments' PSNR (the figures at 4-64 cameras: docs/results.md, Deployment (f)).
# usage: baseline-check.sh BUILD_DIR   (LF_SHARED_DATA: the shared data)
set -euo pipefail
build="$(cd "$1" && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
export GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
data="${LF_SHARED_DATA:-$build/../../shared/data}"
"$build/tools/lf-rig" --input "$data/stanford-chess" --block 0,0,2,4 --input-scale 0.2 \
  --out "$work/rig.json"
"$build/tools/lf-baseline" --rig "$work/rig.json" --frames 15 --sample 2 --qp 11,18,26,34 \
  --size 160x120 --hosts 2 > "$work/out.txt"
cat "$work/out.txt"
awk '/^## summary/{s=1; next} s{v[$1]=$2} END{
  ok = 1
  if (!(v["fragment-bytes"] > 0)) { print "FAIL: no fragment bytes"; ok = 0 }
  if (!(v["jpeg-psnr"] >= 38 && v["jpeg-psnr"] <= 60)) { print "FAIL: JPEG PSNR " v["jpeg-psnr"] " outside 38..60 dB"; ok = 0 }
  if (!(v["h264-bytes"] > 0)) { print "FAIL: H.264 did not reach the JPEG PSNR within the sweep"; ok = 0 }
  else if (!(v["h264-bytes"] < v["jpeg-bytes"])) { print "FAIL: H.264 bytes " v["h264-bytes"] " not below JPEG " v["jpeg-bytes"]; ok = 0 }
  if (!(v["sum-bytes"] > 0 && v["sum-bytes"] < v["fragment-bytes"])) { print "FAIL: partial sums " v["sum-bytes"] " bytes, not below the fragments " v["fragment-bytes"]; ok = 0 }
  if (!(v["camera-frame-psnr"] > 35 && v["sum-frame-psnr"] > v["camera-frame-psnr"] - 2.5)) { print "FAIL: frame PSNR " v["sum-frame-psnr"] " dB with partial sums, " v["camera-frame-psnr"] " with per-camera JPEG fragments"; ok = 0 }
  if (ok) print "ok: JPEG PSNR " v["jpeg-psnr"] " dB; bytes per frame: fragments " v["fragment-bytes"] ", partial sums " v["sum-bytes"] ", JPEG " v["jpeg-bytes"] ", H.264 " v["h264-bytes"] "; frames " v["camera-frame-psnr"] " / " v["sum-frame-psnr"] " dB"
  exit !ok }' "$work/out.txt"
