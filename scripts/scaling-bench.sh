#!/usr/bin/env bash
# Scaling of the in-process pipeline on this machine (issue 38, item 6):
# fps, CPU and latency against the output size (320x240 .. 3840x2160, 64
# Chess cameras) and against the camera count (4 .. 81 Chess cameras and
# 16 .. 256 synthetic ones from lf-rig --synthetic --images, at 640x480), each
# row one lf-gst-bench run (non-live throughput against the kernel bound
# measured in the same run; live latency at 30 requests a second), and a
# least-squares model of the CPU per frame: a + b * output megapixels (the
# size rows) and a + c * cameras (the camera rows), so a deployment can be
# sized. Prints a markdown section; scripts/bench.sh keeps it in
# docs/results/scaling.md and quotes it.
# usage: scripts/scaling-bench.sh [FRAMES]   (default 60 requests a run)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"
data="${DATA:-$root/../shared/data}/stanford-chess"
frames="${1:-60}"
export GST_PLUGIN_PATH="$build/gst"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
# One lf-gst-bench row: size, block[, input] -> "cameras|fps|bound fps|efficiency|CPU ms|live fps|median|p95".
row() {
  local size="$1" block="$2" cams="$3" input="${4:-$data}"
  "$build/tools/lf-gst-bench" --input "$input" --block "$block" --sizes "$size" --encodings raw \
    --frames "$frames" 2> "$tmp/err" | awk -F'|' -v c="$cams" '/^\| [0-9]+x[0-9]+ \| raw \| plane/ {
      gsub(/ /, ""); print c "|" $5 "|" $6 "|" $7 "|" $8 "|" $13 "|" $14 "|" $15 }' || {
    echo "scaling-bench: lf-gst-bench failed at $size, block $block:" >&2; cat "$tmp/err" >&2; exit 1; }
}
echo "Machine: $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1), $(nproc) cores."
echo "Each row: \`lf-gst-bench --input ../shared/data/stanford-chess --block BLOCK --sizes SIZE --encodings raw --frames $frames\`"
echo "(the focal plane; CPU ms per frame is the whole process's, over all cores). Chess has 81"
echo "cameras; the rows marked synthetic use \`lf-rig --synthetic RxR --size 640x480 --images\`"
echo "(a textured disc before a textured background, 640x480 images) to reach 256."
echo
echo "| output | cameras | fps (non-live) | kernel bound fps | pipeline efficiency | CPU ms per frame | CPU ns per output pixel | live fps (30 requests/s) | latency median ms | p95 ms |"
echo "|---|---|---|---|---|---|---|---|---|---|"
: > "$tmp/size"; : > "$tmp/cams"
for size in 320x240 640x480 1280x720 1920x1080 3840x2160; do
  r="$(row "$size" 0,0,8,8 64)"
  echo "$(( ${size%x*} * ${size#*x} ))|$r|$size" >> "$tmp/size"
done
for b in 2 4 6 8 9; do
  r="$(row 640x480 "0,0,$b,$b" $((b * b)))"
  echo "307200|$r|640x480" >> "$tmp/cams"
done
: > "$tmp/syn"
for b in 4 8 16; do
  mkdir -p "$tmp/syn$b"
  "$build/tools/lf-rig" --synthetic "${b}x$b" --size 640x480 --images --out "$tmp/syn$b/rig.json" 2> "$tmp/err" || {
    echo "scaling-bench: lf-rig failed:" >&2; cat "$tmp/err" >&2; exit 1; }
  r="$(row 640x480 "0,0,$b,$b" "$((b * b)) synthetic" "$tmp/syn$b/rig.json")"
  echo "307200|$r|640x480" >> "$tmp/syn"
  rm -rf "$tmp/syn$b"
done
# Fields: 1 pixels, 2 cameras, 3 fps, 4 bound, 5 efficiency, 6 CPU ms, 7 live fps, 8 median, 9 p95, 10 size.
cat "$tmp/size" "$tmp/cams" "$tmp/syn" | awk -F'|' '{
  printf "| %s | %s | %s | %s | %s | %s | %.0f | %s | %s | %s |\n", $10, $2, $3, $4, $5, $6,
         $6 * 1e6 / $1, $7, $8, $9 }'
# Least squares: CPU ms = a + b * x.
fit() { awk -F'|' -v col="$2" '{ x = (col == "px") ? $1 / 1e6 : $2; y = $6; n++; sx += x; sy += y; sxx += x * x; sxy += x * y }
  END { b = (n * sxy - sx * sy) / (n * sxx - sx * sx); a = (sy - b * sx) / n; printf "%.2f %.3f\n", a, b }' "$1"; }
read -r a1 b1 < <(fit "$tmp/size" px)
read -r a2 c2 < <(fit "$tmp/cams" cams)
read -r a3 c3 < <(sed 's/ synthetic//' "$tmp/syn" | fit /dev/stdin cams)
echo
echo "Model (least squares over the rows above): CPU ms per frame = $a1 + $b1 x output megapixels"
echo "(64 cameras), and = $a2 + $c2 x cameras (640x480; synthetic, 16 to 256 cameras: $a3 + $c3 x"
echo "cameras). A camera adds little: each output pixel"
echo "is drawn from about 3 cameras whatever their number (the tent aperture), so the cost"
echo "follows the output pixels; at $b1 ms per megapixel, one core of this machine draws about"
echo "$(awk -v b="$b1" 'BEGIN { printf "%.0f", 1000 / b }') megapixels of output a second."
