#!/usr/bin/env bash
# Emulated 6-host deployment (tools/lf-netem.sh: network namespaces joined by
# veth links): 4 camera hosts x 16 cameras of the real Chess light field, a
# compositor host, a viewer; RTP transport, multicast view requests, shared
# network clock; every run authenticated with SRTP (the default: the
# compositor host's key) except the RTX ones (plain RTP, INSECURE=1).
# Checks, from the hosts' event traces (tools/lf-trace):
#  1. normal run: every request composited, the frames bit-identical (CRC-32)
#     to the single-machine pipeline's for the same requests; clocks agree
#     within 5 ms; capture instants of one frame within one frame period, and
#     all fragments of a frame from the same capture instant;
#  2. camera host 1 killed at 1/3, restarted at 2/3: output keeps flowing
#     within the compositor deadline with the other 48 cameras, and the host
#     rejoins: complete frames again soon after the restart (lf-trace
#     --rejoin-after; with SRTP, lf-launch resets a stream that stops
#     authenticating, else a restarted host was never heard again);
#  3. 5 % packet loss on every link, view requests sent by unicast fan-out
#     instead of multicast: output keeps flowing, nothing hangs;
#  4. the same loss with retransmission (net-host.sh RTX=1): nearly all of
#     the fragment bytes make it into the frames, and the frames are the
#     single-machine pipeline's, bit for bit;
#  5. an attacker (tools/lf-hostile) sending forged packets to every host,
#     on plain RTP with FEC and with RTX (then forged NACKs too), and with
#     the streams' real SSRCs against the default (SRTP): every host keeps
#     running (forged payload types once stopped every camera host) and the
#     frames stay complete (forged SSRCs once kept a stream out for good);
#  6. partial sums (net-host.sh PARTIAL_SUMS=1: each host a 4x4 block of the
#     grid, its fragments added up before they leave): every request
#     composited, complete (the compositor counts a sum's cameras), in
#     fewer bytes than per-camera fragments.
# Requests issued before every camera had captured its first frame (hosts
# start at their own pace) are startup; lf-trace leaves them out.
# usage: net-deploy-check.sh BUILD_DIR SHARED_DATA_DIR
set -euo pipefail
build="$(cd "$1" && pwd)"; data="$2"
if [ ! -d "$data/stanford-chess" ]; then  # 77: meson's "skipped"
  echo "SKIP: needs the real data $data/stanford-chess (absent; scripts/get-data.sh fetches it)"
  exit 77
fi
root="$(cd "$(dirname "$0")/.." && pwd)"
export LF_BUILD_DIR="$build"  # for the pipeline and tool scripts it runs
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# 6 processes share this machine's cores, and the checks must hold with other
# work running: the paper's 320x240 at 10 fps keeps the load at about half a
# core. Complete frames leave the compositor as soon as their last fragment
# is in (27-29 ms median, 36-48 ms p95 with three busy loops, 2 cores),
# so a long deadline costs nothing; it is 300 ms because this shared VM
# stalls now and then for up to 150 ms (capture spread of one frame, CI),
# and a stall must not be taken for a lost fragment.
export RIG="$work/rig.json" FPS=10 LATENCY_MS=300 ENCODING=jpeg QUALITY=90
# RTX: the compositor's jitter buffers wait up to 150 ms for a resent packet
# (net-host.sh's default is 60 ms, sized for its 40 ms deadline): beside a
# busy process in another session (meson starts each test in a session of
# its own, and the kernel's autogroups share the CPU per session, whatever
# the loop's nice), 60 ms left 3-20 of 84-89 frames incomplete in the RTX
# loss run (fragment bytes 0.94-0.99 of the lossless run's; round trip p95
# 253-361 ms), 150 ms none (p95 111-132 ms) in three runs each (2026-11-23).
export RTX_LATENCY_MS=150
normal_s=8 kill_s=15 loss_s=8
export START_MS=6000  # hosts load their images before the shared base time, even when busy
view="orbit=0.6 dolly=15 path-frames=120 width=320 height=240 focal-surface=false"  # the paper's output size and focal plane
export VIEW="$view"
"$build/tools/lf-rig" --input "$data/stanford-chess" --block 0,0,8,8 --input-scale 0.5 --out "$RIG"
period=$(awk -v f=$FPS 'BEGIN{print 1000 / f}')
fail=0
check() {  # check DESCRIPTION AWK-CONDITION  (over the summary's key value pairs)
  local file="$1" what="$2" cond="$3"
  if awk -v what="$what" '/^## summary/{s=1; next} s{v[$1]=$2} END{exit !('"$cond"')}' "$file"; then
    echo "ok: $what"
  else
    echo "FAIL: $what"; fail=1
  fi
}
summary() { sed -n '/^## summary/,$p' "$1" | tr '\n' ' '; echo; }

echo "== single-machine reference (same requests, same rig, JPEG q$QUALITY)"
LF_TRACE="$work/ref.trace" "$root/pipelines/lf-pipeline.sh" "$RIG" "$view num-buffers=200" \
  fakesink "num-buffers=1" "encoding=$ENCODING jpeg-quality=$QUALITY"

echo "== 1. normal run"
"$root/tools/lf-netem.sh" run "$work/normal" $normal_s normal
"$build/tools/lf-trace" --cameras 64 --fps $FPS --reference "$work/ref.trace" "$work"/normal/*.trace \
  > "$work/normal.txt"
cat "$work/normal.txt"
cat "$work/normal/clock-offsets"
summary "$work/normal.txt"
check "$work/normal.txt" "at least 70 % of $((FPS * normal_s)) requests issued" \
  'v["issued"] >= 0.7 * '"$FPS * $normal_s"
check "$work/normal.txt" "every request composited" 'v["composited"] >= v["issued"] - 1'
check "$work/normal.txt" "frames complete (64 fragments)" 'v["complete"] >= 0.95 * v["composited"]'
check "$work/normal.txt" "frames identical to the single-machine pipeline" \
  'v["compared"] >= 0.95 * v["composited"] && v["identical"] == v["compared"]'
# p95 over the frames: a stall of the machine delays a capture now and then
# (max 153 ms seen in CI, median 2 ms); clocks that disagree delay them all.
check "$work/normal.txt" "capture instants of a frame within one period (p95 of frames)" \
  'v["capture-spread-p95-ms"] >= 0 && v["capture-spread-p95-ms"] < '"$period"
check "$work/normal.txt" "fragments of a frame from one capture instant" \
  'v["used-capture-spread-max-ms"] == 0'
last=$(ls "$work"/normal/view-*.png 2>/dev/null | sed 's/.*view-0*\([0-9]*\)\.png/\1/' | sort -n | tail -1)
if [ -n "$last" ] && awk -v n="$last" '/^## summary/{s=1; next} s && $1=="issued"{exit !(n + 1 >= 0.8 * $2)}' "$work/normal.txt"; then
  echo "ok: the viewer received $((last + 1)) output frames (JPEG over RTP)"
else
  echo "FAIL: the viewer received ${last:-no} output frames"; fail=1
fi
if awk '{x = $3 < 0 ? -$3 : $3; if (x >= 5) bad = 1} END{exit bad || NR != 4}' "$work/normal/clock-offsets"; then
  echo "ok: 4 camera hosts' clocks within 5 ms of the compositor host's"
else
  echo "FAIL: clock offsets"; fail=1
fi

echo "== 2. camera host killed and restarted"
"$root/tools/lf-netem.sh" run "$work/kill" $kill_s kill
restart_ns=$(awk '/^restarted/{for (i = 1; i < NF; ++i) if ($i == "clock-ns") print $(i + 1)}' \
  "$work/kill/events")
"$build/tools/lf-trace" --cameras 64 --fps $FPS --timeline --rejoin-after "$restart_ns" \
  "$work"/kill/*.trace > "$work/kill.txt"
cat "$work/kill.txt"
summary "$work/kill.txt"
check "$work/kill.txt" "output flowing while the host is down" 'v["composited"] >= 0.9 * v["issued"]'
# 48 fragments: the other three hosts' cameras, composited at the deadline.
if grep -o ' 48:[0-9]*' "$work/kill.txt" | awk -F: '{exit !($2 >= 25)}'; then
  echo "ok: frames from the remaining 48 cameras during the outage"
else
  echo "FAIL: no run of 48-fragment frames during the outage"; fail=1
fi
# + 250 ms: the restarted host loads its images on the cores the others
# share, and the VM stalls (max gap 450 ms seen in CI with a 120 ms deadline).
check "$work/kill.txt" "no gap longer than period + deadline + 250 ms" \
  'v["max-gap-ms"] < '"$period"' + '"$LATENCY_MS"' + 250'
check "$work/kill.txt" "the restarted host rejoins (last frames complete)" 'v["last-15-complete"] >= 12'
# Restart (the process launched) -> the first complete frame out: the host
# reads its 16 cameras' stills from lfcamsrc's still cache (the first run of
# this host decoded and stored them) while its clock synchronises (lf-launch
# --clock-poll 10 ms: 4 observations), and answers the next request (issue
# 15: within 1 s). In 20 runs of this test (2026-11-23, 10 alone and 10
# beside a niced busy loop, every run passed): 0.31-0.99 s alone (median
# 0.36 s; nine runs under 0.47 s), 0.35-0.50 s beside the loop (median
# 0.40 s). The slow run's outage was 6 frames longer: most likely
# GstNetClientClock, which drops an observation whose round trip is over
# twice its average and asks again only 250 ms later (hard-coded), and
# needs four. Before the still cache, the faster clock sync and the plugin
# without OpenCV's imgcodecs: 0.5-1.4 s alone, 0.8-2.2 s beside the loop.
# With JPEG fragments decoded on arrival and the cameras' shared caps event
# (2026-11-23 night), 20 more runs, all passed: 0.29-0.46 s alone (median
# 0.35 s), 0.33-0.46 s beside the loop (median 0.38 s).
# The check allows 1.5 s, half again the worst seen, so that a busier
# machine (CI) does not fail on that tail; the issue's 1 s held in every run.
check "$work/kill.txt" "complete frames again within 1.5 s of the restart" \
  'v["rejoin-ms"] >= 0 && v["rejoin-ms"] < 1500 && v["rejoin-complete-after"] >= 0.8'

echo "== 3. 5 % packet loss (view requests by unicast fan-out)"
LOSS=0.05 REQUESTS=unicast "$root/tools/lf-netem.sh" run "$work/loss" $loss_s loss
cat "$work/loss/loss"
"$build/tools/lf-trace" --cameras 64 --fps $FPS "$work"/loss/*.trace > "$work/loss.txt"
cat "$work/loss.txt"
summary "$work/loss.txt"
check "$work/loss.txt" "output keeps flowing under loss" \
  'v["composited"] >= 0.85 * v["issued"] && v["issued"] >= 0.7 * '"$FPS * $loss_s"
check "$work/loss.txt" "no gap longer than period + deadline + 250 ms" \
  'v["max-gap-ms"] < '"$period"' + '"$LATENCY_MS"' + 250'

echo "== 4. 5 % packet loss with retransmission (RTX=1)"
# Measured here (2026-11-23): fragment bytes composited per frame
# 0.61-0.64 of the lossless run's without recovery; with RTX=1 see below.
RTX_SHARE=0.97
LOSS=0.05 REQUESTS=unicast RTX=1 INSECURE=1 "$root/tools/lf-netem.sh" run "$work/rtx" $loss_s loss
"$build/tools/lf-trace" --cameras 64 --fps $FPS --reference "$work/ref.trace" "$work"/rtx/*.trace \
  > "$work/rtx.txt"
summary "$work/rtx.txt"
bytes() { awk '/^## summary/{s=1; next} s && $1 == "composited-bytes-per-frame" {print $2}' "$1"; }
normal_bytes=$(bytes "$work/normal.txt"); loss_bytes=$(bytes "$work/loss.txt")
echo "fragment bytes composited per frame: no loss $normal_bytes, loss $loss_bytes, loss with RTX $(bytes "$work/rtx.txt")"
check "$work/rtx.txt" "output keeps flowing under loss with RTX" \
  'v["composited"] >= 0.85 * v["issued"] && v["issued"] >= 0.7 * '"$FPS * $loss_s"
check "$work/rtx.txt" "RTX brings the fragment bytes in the frames to at least $RTX_SHARE of the lossless run's" \
  'v["composited-bytes-per-frame"] >= '"$RTX_SHARE * $normal_bytes"' && v["composited-bytes-per-frame"] > '"$loss_bytes"
check "$work/rtx.txt" "under loss with RTX the frames are the single-machine pipeline's (CRC-32)" \
  'v["compared"] >= 0.9 * v["composited"] && v["identical"] == v["compared"]'

echo "== 5. an attacker beside plain RTP with FEC=25 and with RTX=1 (forged NACKs too), beside"
echo "   the default (SRTP, FEC=25) forging the streams' real SSRCs, and beside plain RTP"
echo "   forging them at 10 packets a second (PLAIN)"
for mode in FEC=25 RTX=1 SRTP PLAIN; do
  rate=1000
  case $mode in
    SRTP) settings="FEC=25 HOSTILE_SSRC=real" ;;
    PLAIN) settings="INSECURE=1 HOSTILE_SSRC=real"; rate=10 ;;
    *) settings="$mode INSECURE=1" ;;
  esac
  # shellcheck disable=SC2086
  if env $settings HOSTILE_RATE=$rate "$root/tools/lf-netem.sh" run "$work/hostile-$mode" 6 hostile; then
    echo "ok: every host survives forged packets with $mode"
  else
    echo "FAIL: a host stopped under forged packets with $mode"; fail=1
    tail -3 "$work"/hostile-"$mode"/*.log
  fi
  "$build/tools/lf-trace" --cameras 64 --fps $FPS "$work"/hostile-"$mode"/*.trace > "$work/hostile-$mode.txt"
  summary "$work/hostile-$mode.txt"
  if [ $mode = PLAIN ]; then continue; fi
  check "$work/hostile-$mode.txt" "frames stay complete beside the attacker with $mode" \
    'v["composited"] >= 0.85 * v["issued"] && v["complete"] >= 0.9 * v["composited"]'
done
# Plain RTP with the real SSRCs and sequences aimed just ahead of the
# viewer's (lf-hostile --follow): lf-launch's RTP sequence and timestamp
# check drops the forged packets, and when the real stream takes the window
# from forged packets that came first, its own packets refused before (its
# in-band caps) go on. Complete frames of the requests issued, measured:
# 63/63 in this test, and 60/61, 65/65, 65/65 with tools/lf-netem.sh alone;
# before the held packets went on (the first second's requests lost) 0.89
# alone and 0.73 once in a full test run; without the check 0.40-0.41
# (25-26 of 63; docs/reliability.md).
check "$work/hostile-PLAIN.txt" "plain RTP: forged packets with the real SSRCs mostly dropped" \
  'v["complete"] >= 0.8 * v["issued"]'
# With the key, a forged packet is dropped whatever SSRC it carries (63 of
# 63 frames complete, measured); without it, see PLAIN above.
check "$work/hostile-SRTP.txt" "with SRTP (the default) forged packets with the real SSRCs change nothing" \
  'v["composited"] >= 0.9 * v["issued"] && v["complete"] >= 0.95 * v["composited"]'
if grep -qx srtp "$work/normal/transport" && grep -qx srtp "$work/kill/transport"; then
  echo "ok: the default deployment is authenticated (SRTP, the compositor host's key)"
else
  echo "FAIL: the default deployment is not SRTP"; fail=1
fi
# The forged NACKs come from the attacker's address: the camera hosts drop
# them by sender (lf-launch --rtcp-from), before they spend the budget that
# the compositor's own NACKs need.
if grep -q "RTCP from a sender not in --rtcp-from dropped" "$work"/hostile-RTX=1/cam*.log; then
  echo "ok: forged NACKs dropped by sender address"
else
  echo "FAIL: no forged NACK dropped by sender address"; fail=1
fi

echo "== 6. partial sums (PARTIAL_SUMS=1)"
PARTIAL_SUMS=1 "$root/tools/lf-netem.sh" run "$work/sums" $normal_s normal
"$build/tools/lf-trace" --cameras 64 --fps $FPS "$work"/sums/*.trace > "$work/sums.txt"
summary "$work/sums.txt"
echo "fragment bytes per frame: per camera $normal_bytes, partial sums $(bytes "$work/sums.txt")"
check "$work/sums.txt" "every request composited with partial sums" \
  'v["composited"] >= v["issued"] - 1 && v["issued"] >= 0.7 * '"$FPS * $normal_s"
check "$work/sums.txt" "frames complete with partial sums (the sums count 64 cameras)" \
  'v["complete"] >= 0.95 * v["composited"]'
# (The figure at 640x480: docs/results.md, Deployment (g).)
check "$work/sums.txt" "partial sums take under 0.7x the bytes of per-camera fragments" \
  'v["composited-bytes-per-frame"] < 0.7 * '"$normal_bytes"
exit $fail
