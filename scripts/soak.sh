#!/usr/bin/env bash
# Soak test of the distributed deployment under attack (issue 11): the live
# 64-camera pipeline (4 camera hosts x 16 cameras of the real Chess light
# field, a compositor host, a viewer; tools/lf-netem.sh namespaces, RTP,
# multicast requests, JPEG fragments, 15 fps) runs SECONDS with an attacker
# host beside it (tools/lf-hostile: random and crafted requests and
# fragments at HOSTILE_RATE packets/s, default 1000), after a run of
# BASELINE_SECONDS without it. Reports, from the hosts' traces and
# /proc: output frame rate of both runs and their ratio, complete frames,
# peak resident memory per host and its growth over the run, the packets
# sent; exits non-zero if a host died, the frame rate fell by more than
# 10 %, or a host's memory grew by more than 64 MiB after the first minute.
#
# SRTP=1 (default): every RTP stream authenticated with a fresh key
# (pipelines/net-host.sh SRTP_KEY), the deployment for untrusted networks;
# SRTP=0: plain RTP, as on a trusted network. HOSTILE_SSRC=real (the
# default with SRTP): the attacker forges the streams' real SSRCs and aims
# its request sequences just ahead of the viewer's (lf-hostile --follow);
# random (the default with SRTP=0): SSRCs of its own. Plain RTP does not
# hold against the real SSRCs at 1,000 packets a second (the attacker's
# packets outnumber the streams': docs/reliability.md).
#
# usage: scripts/soak.sh SECONDS OUTDIR [BASELINE_SECONDS]   (root; default baseline 300)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"
export LF_BUILD_DIR="$build"
seconds="${1:?usage: soak.sh SECONDS OUTDIR [BASELINE_SECONDS]}"; out="${2:?OUTDIR}"
base_seconds="${3:-300}"
data="${LF_DATA:-$root/../shared/data}"
mkdir -p "$out"; out="$(cd "$out" && pwd)"
export RIG="$out/rig.json" FPS=15 LATENCY_MS=40 ENCODING=jpeg QUALITY=90
export VIEW="orbit=0.6 dolly=15 path-frames=120 width=640 height=480"
"$build/tools/lf-rig" --input "$data/stanford-chess" --block 0,0,8,8 --input-scale 0.5 --out "$RIG"
if [ "${SRTP:-1}" = 1 ]; then
  SRTP_KEY=$(head -c 30 /dev/urandom | od -An -tx1 | tr -d ' \n'); export SRTP_KEY
else
  export INSECURE=1  # net-host.sh: plain RTP only when asked
fi
if [ "${SRTP:-1}" = 1 ]; then export HOSTILE_SSRC="${HOSTILE_SSRC:-real}"; fi
fail=0
for run in baseline hostile; do
  s=$seconds; scenario=hostile
  if [ $run = baseline ]; then s=$base_seconds; scenario=normal; fi
  echo "== $run: $s s" >&2
  if ! "$root/tools/lf-netem.sh" run "$out/$run" "$s" "$scenario"; then
    echo "FAIL: a host died in the $run run" >&2; fail=1
  fi
  "$build/tools/lf-trace" --cameras 64 --fps $FPS --timeline "$out/$run"/*.trace > "$out/$run.txt"
done
val() { awk -v k="$2" '/^## summary/{s=1; next} s && $1==k{print $2}' "$1"; }
rate() {  # output frames per second of a run: frames composited / seconds
  awk -v n="$(val "$out/$1.txt" composited)" -v s="$2" 'BEGIN{printf "%.2f", n / s}'
}
fb=$(rate baseline "$base_seconds"); fh=$(rate hostile "$seconds")
ratio=$(awk -v a="$fh" -v b="$fb" 'BEGIN{printf "%.3f", a / b}')
growth() {  # largest growth of a host's VmRSS after the first minute (MiB)
  awk '$1 >= 60 { if (!($2 in first)) first[$2] = $3; if ($3 - first[$2] > g) g = $3 - first[$2] }
       END{printf "%.1f", g / 1024}' "$1"
}
{
  echo "# Soak: live 64-camera deployment with a hostile sender"
  echo
  echo "Command: \`SRTP=${SRTP:-1} scripts/soak.sh $seconds OUT $base_seconds\` ($(nproc) cores, $(date -u +%F))"
  echo
  echo "| run | seconds | issued | composited | complete | output fps | peak RSS per host (MiB) | RSS growth after 60 s (MiB) |"
  echo "|---|---|---|---|---|---|---|---|"
  for run in baseline hostile; do
    s=$seconds; if [ $run = baseline ]; then s=$base_seconds; fi
    peaks=$(awk '{printf "%s%s %.0f", sep, $1, $2 / 1024; sep = ", "}' "$out/$run/rss-peak")
    echo "| $run | $s | $(val "$out/$run.txt" issued) | $(val "$out/$run.txt" composited) |" \
      "$(val "$out/$run.txt" complete) | $(rate $run "$s") | $peaks | $(growth "$out/$run/rss") |"
  done
  echo
  echo "Output frame rate, hostile / baseline: $ratio"
  echo
  echo "Sent by the attacker:"
  echo
  sed 's/^/    /' "$out/hostile/evil.log" | grep -v 'packets,'
} > "$out/soak-report.md"
cat "$out/soak-report.md"
if awk -v r="$ratio" 'BEGIN{exit !(r < 0.9)}'; then echo "FAIL: output frame rate fell by more than 10 %"; fail=1; fi
g=$(growth "$out/hostile/rss")
if awk -v g="$g" 'BEGIN{exit !(g > 64)}'; then echo "FAIL: a host's memory grew by $g MiB"; fail=1; fi
exit $fail
