#!/usr/bin/env bash
# Emulated deployment of the distributed light field camera on one machine
# (root): one network namespace per host, joined by veth links to a bridge
# in a namespace of its own, so nothing touches the machine's own network.
# Runs pipelines/net-host.sh on each host: HOSTS camera hosts (cam0..), one
# compositor host (comp) and one viewer (view), with LF_TRACE event traces
# per host for tools/lf-trace.
#
# usage: lf-netem.sh run OUTDIR SECONDS [SCENARIO]
#   SCENARIO: normal | kill (camera host 1 killed at 1/3 of the run,
#             restarted at 2/3) | loss (LOSS, default 0.05, per RTP packet on
#             every link: tc netem where the kernel has it, else dropped by the
#             senders) | hostile (an attacker host, evil, runs tools/lf-hostile
#             beside the others: random and crafted requests and fragments at
#             HOSTILE_RATE packets/s, default 1000, to the request group, every
#             camera host, the compositor's fragment ports and the viewer;
#             with RTX=1 half of them forged NACKs to the camera hosts;
#             HOSTILE_SSRC=real: with the streams' real SSRCs, and
#             request sequences just ahead of the viewer's, read from the
#             request group)
# Every scenario samples each host's resident memory every 5 s (OUTDIR/rss:
# seconds, host, VmRSS kB) and writes its peak (OUTDIR/rss-peak: host,
# VmHWM kB), and each host's UDP counters at the end (OUTDIR/udp: datagrams
# received, dropped for a full socket buffer, errors) and the bytes its
# link carried (OUTDIR/link-bytes: host, received, sent).
# Every RTP stream is authenticated (SRTP) with the key the compositor host
# makes for the session, unless SRTP_KEY is given or INSECURE=1 (plain RTP;
# RTX=1 needs it); OUTDIR/transport says which (srtp | plain).
# Environment: RIG (required), HOSTS [4], REQUESTS=unicast for a unicast
# fan-out of the view requests (default: multicast), and net-host.sh's settings (FPS,
# ENCODING, VIEW, LATENCY_MS, ...). Writes OUTDIR/{comp,view,cam*}.trace,
# .log, base-time, clock-offsets, the viewer's last output frames
# OUTDIR/view-N.png, and for kill OUTDIR/events (the kill and the restart,
# the restart also on the hosts' shared clock: clock-ns, for lf-trace
# --rejoin-after).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
cmd="${1:-}"; out="${2:-}"; seconds="${3:-}"; scenario="${4:-normal}"
if [ "$cmd" != run ] || [ -z "$out" ] || [ -z "$seconds" ]; then
  sed -n '2,/^set -euo/{/^set -euo/!p}' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
: "${RIG:?RIG must name the rig file}"
if [ "$(id -u)" != 0 ]; then echo "lf-netem.sh: needs root (ip netns)" >&2; exit 2; fi
export HOSTS="${HOSTS:-4}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
tag="lf$$"
sw="${tag}sw"
hosts=(comp view)
for ((k = 0; k < HOSTS; k++)); do hosts+=("cam$k"); done
if [ "$scenario" = hostile ]; then hosts+=(evil); fi
declare -A ip pid
ip[comp]=10.77.0.2; ip[view]=10.77.0.3; ip[evil]=10.77.0.9
for ((k = 0; k < HOSTS; k++)); do ip[cam$k]=10.77.0.$((10 + k)); done

sampler=""
cleanup() {
  # The memory sampler first: left running, it would hold the caller's
  # output open (meson waits for it) after an error.
  if [ -n "$sampler" ]; then kill "$sampler" 2>/dev/null || true; fi
  # The viewer first, so the requests it issued last are answered and
  # composited before the cameras and the compositor go.
  if [ -n "${pid[view]:-}" ]; then kill "${pid[view]}" 2>/dev/null || true; sleep 0.5; fi
  for h in "${!pid[@]}"; do kill "${pid[$h]}" 2>/dev/null || true; done
  sleep 0.3
  for h in "${!pid[@]}"; do kill -9 "${pid[$h]}" 2>/dev/null || true; done
  for h in "${hosts[@]}"; do ip netns del "$tag$h" 2>/dev/null || true; done
  ip netns del "$sw" 2>/dev/null || true
}
trap cleanup EXIT

# Topology: a bridge in namespace $sw; each host's eth0 is a veth into it.
ip netns add "$sw"
ip -n "$sw" link add br0 type bridge
ip -n "$sw" link set br0 type bridge mcast_snooping 0
ip -n "$sw" link set br0 up
netem=0
LOSS="${LOSS:-0.05}"
for h in "${hosts[@]}"; do
  ns="$tag$h"
  ip netns add "$ns"
  ip -n "$sw" link add "${tag}$h" type veth peer name eth0 netns "$ns"
  ip -n "$sw" link set "${tag}$h" master br0 up
  ip -n "$ns" addr add "${ip[$h]}/24" dev eth0
  ip -n "$ns" link set eth0 up
  ip -n "$ns" link set lo up
  ip -n "$ns" route add 224.0.0.0/4 dev eth0
  if [ "$scenario" = loss ]; then
    if ip netns exec "$ns" tc qdisc add dev eth0 root netem loss "$(awk "BEGIN{print $LOSS*100}")%" 2>/dev/null; then
      netem=1
    fi
  fi
done
send_loss=0
if [ "$scenario" = loss ] && [ "$netem" = 0 ]; then send_loss="$LOSS"; fi
echo "loss: scenario=$scenario netem=$netem sender-drop=$send_loss" > "$out/loss"

export COMPOSITOR="${ip[comp]}" VIEWER="${ip[view]}" IFACE=eth0
# REQUESTS=unicast: the viewer sends each request to every camera host
# (multiudpsink fan-out) instead of to the multicast group.
if [ "${REQUESTS:-}" = unicast ]; then
  REQUESTS=""
  for ((k = 0; k < HOSTS; k++)); do REQUESTS+="${REQUESTS:+,}${ip[cam$k]}"; done
  export REQUESTS
fi
# The viewer keeps its last 3 output frames as PNG (the file index counts them).
export OUTPUT="${OUTPUT:-videoconvert ! pngenc compression-level=1 ! multifilesink location=$out/view-%05d.png max-files=3}"
launch() {  # launch HOST ROLE [K]
  local h="$1"; shift
  LF_TRACE="$out/$h.trace" LOSS="$send_loss" ip netns exec "$tag$h" \
    "$root/pipelines/net-host.sh" "$@" >> "$out/$h.log" 2>&1 &
  pid[$h]=$!
}
rm -f "$out"/*.trace "$out"/*.log "$out"/view-*.png
# The compositor host publishes the clock and picks the base time.
BASE_TIME="now+${START_MS:-4000}" launch comp compositor
for _ in $(seq 100); do
  if grep -q '^base-time ' "$out/comp.log" 2>/dev/null; then break; fi
  sleep 0.1
done
BASE_TIME="$(awk '/^base-time /{print $2; exit}' "$out/comp.log")"
if [ -z "$BASE_TIME" ]; then echo "lf-netem.sh: the compositor host did not start:" >&2; cat "$out/comp.log" >&2; exit 1; fi
export BASE_TIME
echo "$BASE_TIME" > "$out/base-time"
# The session's SRTP key, made and printed by the compositor host (unless
# SRTP_KEY was given, or INSECURE=1 asks for plain RTP), handed to every other host.
if [ -z "${SRTP_KEY:-}" ] && [ "${INSECURE:-0}" != 1 ]; then
  SRTP_KEY="$(awk '/^srtp-key /{print $2; exit}' "$out/comp.log")"
  if [ -z "$SRTP_KEY" ]; then echo "lf-netem.sh: the compositor host printed no srtp-key:" >&2; cat "$out/comp.log" >&2; exit 1; fi
  export SRTP_KEY
fi
if [ -n "${SRTP_KEY:-}" ]; then echo srtp; else echo plain; fi > "$out/transport"
: > "$out/clock-offsets"
for ((k = 0; k < HOSTS; k++)); do
  ip netns exec "$tag"cam$k "$build/tools/lf-launch" --clock-client "${ip[comp]}:${CLOCK_PORT:-5300}" \
    --check-clock | sed "s/^/cam$k /" >> "$out/clock-offsets" || true
  launch "cam$k" camera "$k"
done
launch view viewer
echo "lf-netem.sh: $HOSTS camera hosts, compositor, viewer; base time $BASE_TIME; $scenario run of ${seconds}s" >&2
start=$(date +%s.%N)
: > "$out/rss"
sample_rss() {  # every 5 s: seconds since start, host, VmRSS (kB)
  while :; do
    for h in "${!pid[@]}"; do
      r=$(awk '/^VmRSS:/{print $2}' "/proc/${pid[$h]}/status" 2>/dev/null || true)
      if [ -n "$r" ]; then echo "$(awk "BEGIN{printf \"%.0f\", $(date +%s.%N) - $start}") $h $r" >> "$out/rss"; fi
    done
    sleep 5
  done
}
sample_rss &
sampler=$!
if [ "$scenario" = hostile ]; then
  # HOSTILE_SSRC=real: every forged RTP packet carries its stream's real
  # SSRC (net-host.sh's fixed ones), as after seeing one packet of it.
  real=0
  if [ "${HOSTILE_SSRC:-random}" = real ]; then real=1; fi
  ssrc() { if [ "$real" = 1 ]; then echo "/$1"; fi; }
  targets=(--fragments "${ip[view]}:${VIDEO_PORT:-5100}$(ssrc 12288)")
  group=""  # the multicast group of the view requests, if they use one
  if [[ "${REQUESTS:-239.255.42.1}" =~ ^2(2[4-9]|3[0-9])\. ]]; then group="${REQUESTS:-239.255.42.1}"; fi
  if [ -n "$group" ]; then targets+=(--requests "$group:${REQUEST_PORT:-5000}$(ssrc 4096)"); fi
  for ((k = 0; k < HOSTS; k++)); do
    targets+=(--requests "${ip[cam$k]}:${REQUEST_PORT:-5000}$(ssrc 4096)")
    targets+=(--fragments "${ip[comp]}:$((${FRAGMENT_PORT:-5200} + k))$(ssrc $((8192 + k)))")
    # RTX=1: forged NACKs for each camera host's stream (SSRC 8192 + K),
    # where it reads them (the request group, or its own address).
    if [ "${RTX:-0}" = 1 ]; then
      targets+=(--nacks "${group:-${ip[cam$k]}}:$((${NACK_PORT:-5400} + k)):$((8192 + k))")
    fi
  done
  # With the real SSRCs the attacker also reads the request group and aims
  # its sequences just ahead of the viewer's (lf-hostile --follow).
  if [ "$real" = 1 ] && [ -n "$group" ]; then targets+=(--follow "$group:${REQUEST_PORT:-5000}"); fi
  # The attacker forges the rig's real camera ids too.
  ids=$("$build/tools/lf-rig" --input "$RIG" --ids | tr -s ' \n' ',' | sed 's/,$//')
  ip netns exec "$tag"evil "$build/tools/lf-hostile" "${targets[@]}" --camera-ids "$ids" \
    --rate "${HOSTILE_RATE:-1000}" --duration "$(awk "BEGIN{print $seconds + (${START_MS:-4000}) / 1000}")" \
    > "$out/evil.log" 2>&1 &
  evil=$!
fi
sleep "$(awk "BEGIN{print (${START_MS:-4000})/1000}")"
case "$scenario" in
  kill)
    third=$(awk "BEGIN{print $seconds/3}")
    sleep "$third"
    kill -9 "${pid[cam1]}" 2>/dev/null || true
    echo "killed cam1 at $(date +%s.%N)" >> "$out/events"
    sleep "$third"
    # The restart on the hosts' shared clock too (lf-trace --rejoin-after).
    echo "restarted cam1 at $(date +%s.%N) clock-ns $("$build/tools/lf-trace" --clock-now)" \
      >> "$out/events"
    launch cam1 camera 1
    sleep "$third"
    ;;
  *) sleep "$seconds" ;;
esac
# Still running? (A host that died early is an error.)
kill "$sampler" 2>/dev/null || true
: > "$out/rss-peak"
for h in "${!pid[@]}"; do
  echo "$h $(awk '/^VmHWM:/{print $2}' "/proc/${pid[$h]}/status" 2>/dev/null || echo gone)" >> "$out/rss-peak"
done
if [ -n "${evil:-}" ]; then wait "$evil" || true; fi
# UDP counters of each host's namespace (/proc/net/snmp): datagrams received,
# and those the kernel dropped for a full socket buffer (a receiver that did
# not read in time) or other errors.
echo "host in-datagrams rcvbuf-errors in-errors" > "$out/udp"
for h in "${hosts[@]}"; do
  ip netns exec "$tag$h" awk -v h="$h" '$1 == "Udp:" && $2 ~ /^[0-9]/ {print h, $2, $6, $4}' \
    /proc/net/snmp >> "$out/udp" 2>/dev/null || true
done
# Bytes each host's link carried (IP packets, both ways; RTP, RTCP, FEC and
# clock traffic alike): host, received, sent.
echo "host rx-bytes tx-bytes" > "$out/link-bytes"
for h in "${hosts[@]}"; do
  echo "$h $(ip netns exec "$tag$h" cat /sys/class/net/eth0/statistics/rx_bytes \
    /sys/class/net/eth0/statistics/tx_bytes 2>/dev/null | tr '\n' ' ')" >> "$out/link-bytes"
done
status=0
for h in "${!pid[@]}"; do
  if ! kill -0 "${pid[$h]}" 2>/dev/null; then
    echo "lf-netem.sh: host $h exited early:" >&2; tail -5 "$out/$h.log" >&2; status=1
  fi
done
elapsed=$(awk "BEGIN{print $(date +%s.%N) - $start}")
echo "lf-netem.sh: done after ${elapsed}s" >&2
exit $status
