#!/usr/bin/env bash
# Measurements of the distributed system in the emulated deployment
# (tools/lf-netem.sh; root): prints markdown tables and writes plots.
#  (a) the paper's Figure 6: fragment bytes entering the compositor per
#      output frame for 4, 16 and 64 cameras spread over the 8x8 Chess array
#      (lf-rig --spread), raw and JPEG;
#  (b) the all-viewpoints baseline (paper 3.1): every camera streams its JPEG
#      video (stock jpegenc at the same quality, rtpjpegpay) to the
#      compositor host; bytes per output frame = one frame of every camera;
#  (c) the paper's Figure 5: round-trip latency and its components, 64
#      cameras, JPEG and raw fragments;
#  (d) overload: the JPEG run of (c) again beside a niced CPU loop
#      (`nice -n 19`, one core's worth), round trip against (c)'s;
#  (e) loss: the JPEG run of (c) with LOSS (5 %) of the RTP packets dropped
#      on every link, without recovery, with forward error correction
#      (net-host.sh FEC=25, 50) and with retransmission (RTX=1), and FEC=25
#      and RTX=1 without loss (their cost): fragment bytes in the frames and
#      bytes into the compositor's link against (c)'s, complete frames,
#      frames identical to (c)'s for the same requests, round trip;
#  (f) stronger all-viewpoints baselines (tools/lf-baseline, in process): on
#      the synthetic dynamic scene with sensor noise, fragments (JPEG) and
#      partial sums of 4 hosts (contiguous blocks) against every camera
#      streaming JPEG or H.264 video at the same PSNR, 4, 16 and 64 cameras;
#  (g) partial sums in the deployment (net-host.sh PARTIAL_SUMS=1): the
#      64-camera JPEG run of (c) with each host's fragments added up, and a
#      camera host killed and restarted, with blocks and with (c)'s
#      interleaved hosts: bytes, round trip, the pixels a dead host leaves
#      uncovered, how soon the restarted host is back in complete frames.
# usage: lf-netbench.sh [OUTDIR] [SECONDS per run]   (default out/netbench, 8)
# Environment: FPS [15], QUALITY [90], WIDTH x HEIGHT [640x480], INPUT_SCALE
# of the camera images [0.5: 700x400], DATA [../shared/data].
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
out="${1:-$root/out/netbench}"; seconds="${2:-8}"
mkdir -p "$out"; out="$(cd "$out" && pwd)"
data="${DATA:-$root/../shared/data}"
export FPS="${FPS:-15}" QUALITY="${QUALITY:-90}" LATENCY_MS="${LATENCY_MS:-40}"
W="${WIDTH:-640}"; H="${HEIGHT:-480}"; scale="${INPUT_SCALE:-0.5}"
export VIEW="orbit=0.6 dolly=15 path-frames=120 width=$W height=$H"
trace="$build/tools/lf-trace"
key() { awk -v k="$2" '/^## summary/{s=1; next} s && $1==k {print $2}' "$1"; }

declare -A bytes
for k in 2 4 8; do
  n=$((k * k))
  rig="$out/rig$n.json"
  "$build/tools/lf-rig" --input "$data/stanford-chess" --block 0,0,8,8 --spread "$k" \
    --input-scale "$scale" --out "$rig"
  for enc in raw jpeg; do
    run="$out/$enc$n"
    echo "== $n cameras, $enc fragments ($seconds s)" >&2
    RIG="$rig" HOSTS=$((n < 4 ? n : 4)) ENCODING=$enc "$root/tools/lf-netem.sh" run "$run" "$seconds" normal
    "$trace" --cameras "$n" --fps "$FPS" "$run"/*.trace --plot "$out/latency-$enc$n.png" > "$run.txt"
    bytes[$enc$n]=$(key "$run.txt" bytes-per-frame)
  done
done

echo "== overload: 64 cameras, jpeg fragments beside a niced busy loop ($seconds s)" >&2
nice -n 19 sh -c 'while :; do :; done' &
busy=$!
RIG="$out/rig64.json" HOSTS=4 ENCODING=jpeg "$root/tools/lf-netem.sh" run "$out/busy64" "$seconds" normal ||
  { kill "$busy"; exit 1; }
kill "$busy"
"$trace" --cameras 64 --fps "$FPS" "$out"/busy64/*.trace > "$out/busy64.txt"

# recovery RUN SCENARIO SETTING...: a 64-camera JPEG run with net-host.sh
# settings, its frames compared with (c)'s (same requests). Plain RTP
# (INSECURE=1) for all of them: RTX works only without SRTP, and FEC and RTX
# are compared on the same transport.
recovery() {
  local run="$1" scenario="$2"; shift 2
  echo "== $scenario, 64 cameras, jpeg fragments, $* ($seconds s)" >&2
  env RIG="$out/rig64.json" HOSTS=4 ENCODING=jpeg INSECURE=1 "$@" "$root/tools/lf-netem.sh" run "$out/$run" "$seconds" "$scenario"
  "$trace" --cameras 64 --fps "$FPS" --reference "$out/jpeg64/comp.trace" "$out/$run"/*.trace > "$out/$run.txt"
}
for f in 0 25 50; do recovery "loss-fec$f" loss FEC=$f; done
recovery loss-rtx loss RTX=1
recovery fec25 normal FEC=25
recovery rtx normal RTX=1

echo "== partial sums, 64 cameras, jpeg ($seconds s; then a host killed, blocks and interleaved)" >&2
RIG="$out/rig64.json" HOSTS=4 ENCODING=jpeg PARTIAL_SUMS=1 "$root/tools/lf-netem.sh" run "$out/sums64" "$seconds" normal
"$trace" --cameras 64 --fps "$FPS" "$out"/sums64/*.trace > "$out/sums64.txt"
for p in 1 0; do
  RIG="$out/rig64.json" HOSTS=4 ENCODING=jpeg PARTIAL_SUMS=$p "$root/tools/lf-netem.sh" run "$out/kill-sums$p" "$seconds" kill
  restart_ns=$(awk '/^restarted/{for (i = 1; i < NF; ++i) if ($i == "clock-ns") print $(i + 1)}' \
    "$out/kill-sums$p/events")
  "$trace" --cameras 64 --fps "$FPS" --rejoin-after "$restart_ns" "$out"/kill-sums$p/*.trace \
    > "$out/kill-sums$p.txt"
done

for n in 4 16 64; do
  echo "== all-viewpoints JPEG and H.264 against fragments, synthetic scene with noise, $n cameras" >&2
  GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}" "$build/tools/lf-baseline" --rig "$out/rig$n.json" --fps "$FPS" --quality "$QUALITY" \
    --size "${W}x${H}" > "$out/codec$n.txt"
done

echo "== all-viewpoints baseline, 64 cameras, jpegenc quality=$QUALITY ($seconds s)" >&2
rm -rf "$out/baseline-frames"
RIG="$out/rig64.json" HOSTS=4 BASELINE="$out/baseline-frames" INSECURE=1 \
  "$root/tools/lf-netem.sh" run "$out/baseline" "$seconds" normal
if ! ls "$out"/baseline-frames/cam*-*.jpg > /dev/null 2>&1; then
  echo "lf-netbench.sh: the baseline run delivered no JPEG frames (see $out/baseline/*.log)" >&2
  exit 1
fi
# Mean JPEG bytes per camera frame, summed over the cameras (first frames skipped).
base=$(for f in "$out"/baseline-frames/cam*-*.jpg; do
  n="${f##*-}"; n="${n%.jpg}"; [ "$((10#$n))" -ge 3 ] && stat -c '%s %n' "$f"; done |
  awk '{split($2, p, "/cam"); split(p[2], q, "-"); s[q[1]] += $1; c[q[1]]++}
       END{for (k in s) {t += s[k] / c[k]; n++} printf "%.0f %d", t, n}')
base_bytes=${base% *}; base_cams=${base#* }

{
  echo "# Distributed light field camera: emulated deployment measurements"
  echo
  echo "$(date -u +%F), $(nproc) cores, ${W}x${H} output, $FPS requests/s, camera images scaled by $scale,"
  echo "JPEG quality $QUALITY, compositor deadline $LATENCY_MS ms, ${seconds} s per run."
  echo "Command: tools/lf-netbench.sh $*"
  echo
  echo "## (a) Fragment bytes per output frame (paper Figure 6)"
  echo
  echo "| cameras (spread over the 8x8 array) | raw bytes/frame | JPEG bytes/frame | raw vs 64 | JPEG vs 64 |"
  echo "|---|---|---|---|---|"
  for n in 4 16 64; do
    awk -v n=$n -v r="${bytes[raw$n]}" -v j="${bytes[jpeg$n]}" -v r64="${bytes[raw64]}" -v j64="${bytes[jpeg64]}" \
      'BEGIN{printf "| %d | %.0f | %.0f | %.3f | %.3f |\n", n, r, j, r / r64, j / j64}'
  done
  echo
  echo "## (b) All-viewpoints baseline (paper 3.1), same JPEG quality"
  echo
  awk -v b="$base_bytes" -v c="$base_cams" -v j="${bytes[jpeg64]}" -v r="${bytes[raw64]}" 'BEGIN{
    printf "| design | bytes per output frame | ratio |\n|---|---|---|\n";
    printf "| all-viewpoints: %d cameras stream JPEG video | %.0f | 1 |\n", c, b;
    printf "| fragments, JPEG (64 cameras) | %.0f | %.1fx less |\n", j, b / j;
    printf "| fragments, raw (64 cameras) | %.0f | %.2fx of it |\n", r, r / b}'
  for enc in jpeg raw; do
    echo
    echo "## (c) Round-trip latency, 64 cameras, $enc fragments (paper Figure 5)"
    echo
    sed -n '/^## Latency/,/^## Capture/p' "$out/${enc}64.txt" | sed '1,2d;$d'
  done
  echo
  echo "## (d) Overload: 64 cameras, JPEG fragments, beside a niced busy loop"
  echo
  echo "| run | frames composited / issued | complete | round trip median ms | p95 ms |"
  echo "|---|---|---|---|---|"
  for r in jpeg64 busy64; do
    label=$([ $r = busy64 ] && echo "beside \`nice -n 19\` busy loop" || echo "alone ((c) above)")
    echo "| $label | $(key "$out/$r.txt" composited) / $(key "$out/$r.txt" issued) |" \
      "$(key "$out/$r.txt" complete) | $(key "$out/$r.txt" round-trip-median-ms) |" \
      "$(key "$out/$r.txt" round-trip-p95-ms) |"
  done
  awk -v q="$(key "$out/jpeg64.txt" round-trip-p95-ms)" -v b="$(key "$out/busy64.txt" round-trip-p95-ms)" \
    'BEGIN{printf "\np95 beside the loop / alone: %.2f (target: at most 2)\n", b / q}'
  echo
  echo "## (e) Loss: ${LOSS:-0.05} of the RTP packets dropped on every link, 64 cameras, JPEG fragments"
  echo
  echo "FEC: net-host.sh FEC=N (RFC 5109 ULPFEC, rtpulpfecenc percentage=N; receivers"
  echo "rtpstorage ! rtpjitterbuffer latency=FEC_LATENCY_MS [30] ! rtpulpfecdec). RTX: net-host.sh"
  echo "RTX=1 (RFC 4588 retransmission on RTCP NACKs; rtpjitterbuffer latency=RTX_LATENCY_MS [60])."
  echo "Against the lossless run of (c): fragment bytes in the frames (composited before the"
  echo "deadline; in brackets, those that entered the compositor, late ones too), frames"
  echo "bit-identical to (c)'s for the same requests, and bytes into the compositor's link per"
  echo "composited frame (media, FEC, RTCP, clock)."
  echo
  echo "| run | fragment bytes in the frames (entered) | complete frames | complete frames identical to (c) | link bytes per frame | round trip median ms | p95 ms |"
  echo "|---|---|---|---|---|---|---|"
  linkpf() { awk -v n="$(key "$2" composited)" '$1 == "comp" {printf "%.0f", $2 / n}' "$1/link-bytes"; }
  ref_bytes=$(key "$out/jpeg64.txt" composited-bytes-per-frame); ref_link=$(linkpf "$out/jpeg64" "$out/jpeg64.txt")
  for r in jpeg64 fec25 rtx loss-fec0 loss-fec25 loss-fec50 loss-rtx; do
    case $r in
      jpeg64) label="no loss, no recovery ((c) above)" ;;
      fec25) label="no loss, FEC 25 %" ;;
      rtx) label="no loss, RTX" ;;
      loss-fec0) label="loss, no recovery" ;;
      loss-rtx) label="loss, RTX" ;;
      *) label="loss, FEC ${r#loss-fec} %" ;;
    esac
    awk -v l="$label" -v b="$(key "$out/$r.txt" composited-bytes-per-frame)" -v e="$(key "$out/$r.txt" bytes-per-frame)" -v rb="$ref_bytes" \
      -v c="$(key "$out/$r.txt" complete)" -v n="$(key "$out/$r.txt" composited)" \
      -v cmp="$(key "$out/$r.txt" compared)" -v same="$(key "$out/$r.txt" identical)" \
      -v lk="$(linkpf "$out/$r" "$out/$r.txt")" -v rl="$ref_link" \
      -v m="$(key "$out/$r.txt" round-trip-median-ms)" -v p="$(key "$out/$r.txt" round-trip-p95-ms)" \
      'BEGIN{printf "| %s | %.0f (%.1f %%) (%.1f %%) | %d / %d | %s | %.0f (%.2fx) | %s | %s |\n", l, b, 100 * b / rb, 100 * e / rb, c, n, (cmp == "" ? "-" : same " / " cmp), lk, lk / rl, m, p}'
  done
  echo
  echo "## (f) All-viewpoints JPEG and H.264 against fragments (synthetic scene, sensor noise)"
  echo
  echo "tools/lf-baseline: the rigs of (a) with lfcamsrc mode=synthetic noise=2 (a textured disc"
  echo "moving over a textured plane; Gaussian noise of 2 levels, fresh every frame); fragments"
  echo "JPEG q$QUALITY; every camera's video through jpegenc q$QUALITY, or openh264enc at the"
  echo "constant quantiser that gives the JPEG's PSNR of the camera images (I420; interpolated"
  echo "between the two nearest QPs of a sweep, keyframe every 2 s), measured on up to 8 cameras"
  echo "and scaled to all. Partial sums: 4 camera hosts, each a contiguous block of the grid"
  echo "(lf-rig --hosts 4), its fragments added up (lfcamerahost partial-sums=true) and sent as one"
  echo "JPEG q$QUALITY. Frame PSNR: the composited frames of the Chess images (no noise) against"
  echo "those of raw per-camera fragments, for per-camera JPEG fragments / partial sums."
  echo
  echo "| cameras | fragments bytes/frame | partial sums of 4 hosts | all-viewpoints JPEG | all-viewpoints H.264, same PSNR | PSNR dB | frame PSNR dB, per camera / sums |"
  echo "|---|---|---|---|---|---|---|"
  for n in 4 16 64; do
    c="$out/codec$n.txt"
    awk -v n=$n -v f="$(key "$c" fragment-bytes)" -v j="$(key "$c" jpeg-bytes)" \
      -v h="$(key "$c" h264-bytes)" -v p="$(key "$c" jpeg-psnr)" -v s="$(key "$c" sum-bytes)" \
      -v fc="$(key "$c" camera-frame-psnr)" -v fs="$(key "$c" sum-frame-psnr)" \
      'BEGIN{printf "| %d | %.0f | %.0f (%.2fx the fragments; all-viewpoints JPEG / it: %.1fx) | %.0f (%.1fx the fragments) | %s | %.2f | %.2f / %.2f |\n",
        n, f, s, s / f, j / s, j, j / f,
        (h > 0 ? sprintf("%.0f (%.2fx the fragments)", h, h / f) : "outside the QP sweep"), p, fc, fs}'
  done
  echo
  echo "## (g) Partial sums in the deployment, 64 cameras, JPEG"
  echo
  echo "net-host.sh PARTIAL_SUMS=1: camera host K serves the K-th 4x4 block of the grid and sends"
  echo "one sum per request. Kill: camera host 1 killed at 1/3 of the run, restarted at 2/3; filled"
  echo "pixels: those no fragment covered, taken from the frame before (mean over all frames);"
  echo "rejoin: from the restarted host's launch to the first complete frame out (lf-trace --rejoin-after)."
  echo
  echo "| run | fragment bytes in the frames | complete frames | round trip median ms | p95 ms | filled pixels per frame | rejoin ms |"
  echo "|---|---|---|---|---|---|---|"
  for r in jpeg64 sums64 kill-sums0 kill-sums1; do
    case $r in
      jpeg64) label="per camera, interleaved hosts ((c) above)" ;;
      sums64) label="partial sums, blocks" ;;
      kill-sums0) label="per camera, interleaved hosts, a host killed" ;;
      kill-sums1) label="partial sums, blocks, a host killed" ;;
    esac
    echo "| $label | $(key "$out/$r.txt" composited-bytes-per-frame) |" \
      "$(key "$out/$r.txt" complete) / $(key "$out/$r.txt" composited) |" \
      "$(key "$out/$r.txt" round-trip-median-ms) | $(key "$out/$r.txt" round-trip-p95-ms) |" \
      "$(key "$out/$r.txt" filled-pixels-per-frame) | $(case $r in kill-*) key "$out/$r.txt" rejoin-ms ;; *) echo - ;; esac) |"
  done
} > "$out/report.md"
"$trace" --bandwidth-plot "$out/figure6.png" \
  "raw fragments=4:${bytes[raw4]},16:${bytes[raw16]},64:${bytes[raw64]}" \
  "JPEG fragments=4:${bytes[jpeg4]},16:${bytes[jpeg16]},64:${bytes[jpeg64]}" \
  "all-viewpoints JPEG=64:$base_bytes" >&2
cat "$out/report.md"
echo "report: $out/report.md; plots: $out/figure6.png, $out/latency-jpeg64.png, $out/latency-raw64.png" >&2
