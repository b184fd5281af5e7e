#!/usr/bin/env bash
# One host of the distributed light field camera (Yang et al. 2002, Figure 2,
# Section 4.4): camera hosts, a compositor host and a viewer, joined by RTP
# over UDP (rtpgstpay/rtpgstdepay: fragments and view requests cross as
# buffers tagged in band), on one shared network clock and base time
# (tools/lf-launch: GstNetTimeProvider on the compositor host,
# GstNetClientClock elsewhere).
#
# usage: net-host.sh compositor | camera K | viewer
# Settings (environment; defaults in brackets):
#   RIG          rig file, the same on every host (tools/lf-rig makes one)   [required]
#   HOSTS        number of camera hosts; camera i of the rig (rig order) is
#                served by camera host i % HOSTS (PARTIAL_SUMS=1: blocks)    [4]
#   COMPOSITOR   compositor host's address (fragments, clock)               [127.0.0.1]
#   VIEWER       viewer's address (output video)                            [127.0.0.1]
#   REQUESTS     where view requests go: a multicast group (224-239.x.x.x),
#                joined by every camera host, or a unicast fan-out list
#                "IP,IP,..." of the camera hosts                            [239.255.42.1]
#   IFACE        multicast interface (camera hosts, viewer)                 [system default]
#   BASE_TIME    base time on the shared clock (ns), printed by the compositor
#                host as "base-time NS"; there: now+MS                      [now+3000]
#   CLOCK_PORT   UDP port of the clock provider                             [5300]
#   REQUEST_PORT / FRAGMENT_PORT / VIDEO_PORT: UDP ports; camera host K sends
#                its fragments to FRAGMENT_PORT + K                         [5000/5200/5100]
#   FPS          request and capture rate                                   [15]
#   ENCODING     fragment encoding raw | jpeg; QUALITY JPEG quality         [jpeg/90]
#   LATENCY_MS   compositor deadline after a request's time                 [40]
#   VIEW         lfviewrequest properties (viewer)
#                [orbit=0.6 dolly=15 path-frames=120 width=640 height=480]
#   PHASE_NS     capture phase: cameras capture at k / FPS + PHASE_NS, requests
#                are issued at k / FPS. Every camera warps the frame captured
#                at or before the time the request carries (the viewer's PTS on
#                the shared clock; lffragment frame-select=capture-time), so all
#                fragments of a request come from one capture instant even when
#                a busy host captures late or a request arrives late; half a
#                period apart, that frame is already there     [half a period]
#   OUTPUT       viewer: sink for the decoded output video                  [fakesink]
#   DURATION     stop after this many seconds (default: run until killed)
#   LOSS         probability (0..1) to drop each outgoing RTP packet, for tests
#                on networks without tc netem                               [0]
#   BASELINE=DIR the all-viewpoints baseline (paper 3.1) instead: every camera
#                streams its JPEG video (stock jpegenc quality=QUALITY, rtpjpegpay)
#                to the compositor host, which stores the received JPEG frames
#                as DIR/cam<ID>-<N>.jpg (camera i uses port BASELINE_PORT + i) [6000]
#   SRTP_KEY     60 hex digits (AES-128 key + salt) shared by every host:
#                every RTP stream is authenticated and encrypted (srtpenc /
#                srtpdec, RFC 3711, AES-128-ICM + HMAC-SHA1-80), so packets
#                from anyone without the key are dropped before they reach
#                a depayloader; each start of a host encrypts under a key
#                of its own, derived from this one (tools/launch_srtp.h);
#                `head -c 30 /dev/urandom | od -An -tx1 |
#                tr -d ' \n'` makes one. Each stream has a fixed SSRC
#                (requests 4096, camera host K's fragments 8192 + K, video
#                12288). Unset: the compositor host makes a fresh key and
#                prints it ("srtp-key HEX", beside "base-time NS"); every
#                other host refuses to start without it        [made by the compositor]
#   INSECURE=1   plain RTP instead, only on a trusted network: anyone who can
#                send to a host's ports with a stream's SSRC can then forge
#                requests and fragments (docs/reliability.md). RTX=1 and
#                BASELINE need it (neither works with SRTP)                 [0]
#   FEC          forward error correction on every RTP stream, in percent of
#                its packets (RFC 5109 ULPFEC: rtpulpfecenc; the receivers
#                rtpstorage ! rtpjitterbuffer ! rtpulpfecdec ! rtpptdemux,
#                which drops the parity packets): parity packets over each
#                fragment, request or video frame, as the budget allows, each
#                rebuilding one lost packet of those it covers. The view
#                requests (one small packet each) always get one (a lost
#                request costs a host's every fragment of it). lf-launch
#                --rtp-clock-rate 122=90000 tells the jitter buffers the parity
#                packets' clock rate (without it they dropped every parity
#                packet and waited out their latency for the gap: round trip
#                +18 ms without any loss); their latency adds to the
#                compositor's deadline.
#                Its effect under loss: docs/results.md (Deployment, (e)).
#                Every stream's SSRC is in its receiver's caps, and lf-launch
#                drops packets of any other SSRC before the jitter buffers and
#                depayloaders (lf-netem.sh's hostile run: every frame
#                complete); forged packets carrying a stream's own SSRC still
#                upset its jitter buffer: on an untrusted network set SRTP_KEY
#                too; net-host.sh warns. 0 = off, as before                [0]
#   FEC_LATENCY_MS  how long a receiver waits for a lost packet before it
#                gives up on it (rtpjitterbuffer latency; 10 ms lost more
#                packets than it recovered on bursts of fragments)      [30]
#   REQUEST_FEC_LATENCY_MS  the same for the view requests (one packet and
#                its parity packet, back to back: at 30 ms a lost request
#                reached every camera host after the compositor's deadline,
#                as the multicast leaves the viewer's link once)         [5]
#   RTX=1        retransmission of the fragments instead of FEC (RFC 4588;
#                GStreamer's elements without rtpbin, as rtprtxreceive's
#                documentation lays them out): each camera host keeps
#                RTX_KEEP_MS of its packets (rtprtxsend) behind an rtpsession
#                (RTP/AVPF); the compositor's rtpsession ! rtprtxreceive !
#                rtpjitterbuffer do-retransmission=true asks for each missing
#                packet (RTCP NACK, RFC 4585) at camera host K's UDP port
#                NACK_PORT + K, at REQUESTS (the multicast group, or the K-th
#                address of the fan-out list). lf-launch gives the requests
#                their stream's SSRC and caps each camera host's answers at
#                --rtx-budget (25 %) of the packets it sent; a camera host
#                takes NACKs only from COMPOSITOR's address (lf-launch
#                --rtcp-from, when COMPOSITOR is an IP address), so forged
#                NACKs from elsewhere cannot spend that budget. The view
#                requests get FEC 100. Not with SRTP_KEY (srtpdec knows each
#                stream's own SSRC only, not its retransmissions'); without
#                it, forged packets with a stream's SSRC upset the jitter
#                buffer as with FEC: net-host.sh warns.
#                Its effect under loss: docs/results.md (Deployment, (e)) [0]
#   RTX_LATENCY_MS  how long the compositor waits for a missing packet
#                (rtpjitterbuffer latency; adds to its deadline when a packet
#                is missing). The jitter buffer counts it from the packet's
#                RTP timestamp, which a request's whole burst of fragments
#                from one host shares (20-30 ms of packets): at 30 the last
#                packets of a burst had a few ms, and 7-19 % of the fragment
#                bytes missed the frame. On a loaded host give it more, up to
#                the deadline: beside a busy process 60 left 3-20 of ~85
#                frames incomplete under 5 % loss, 150 none (300 ms deadline,
#                tests/net-deploy-check.sh)                                 [60]
#   RTX_KEEP_MS  how long a camera host keeps its packets for resending  [200]
#   NACK_PORT    RTX: camera host K reads NACKs on UDP port NACK_PORT + K [5400]
#   PARTIAL_SUMS=1  camera hosts serve contiguous blocks of the grid
#                (lf-rig --hosts HOSTS) instead of every HOSTS-th camera, and
#                each adds up its cameras' fragments of a request before
#                sending one (lfcamerahost partial-sums=true: lfpartialsum;
#                premultiplied colour and weight, so the compositor's
#                renormalisation gives the same frame). Fewer bytes (the
#                block's part of the view once, not about three times:
#                tools/lf-baseline), but a dead host leaves a hole where only
#                its block sees (with interleaved hosts the neighbours cover
#                it)                                                         [0]
#   SUM_LATENCY_MS  PARTIAL_SUMS: a sum leaves this long after its request's
#                time with the cameras that answered, when one has not
#                (inside the compositor's LATENCY_MS)            [LATENCY_MS/2]
#   PRINT=1      print the lf-launch command instead of running it
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"  # the build directory (scripts/setup.sh: LF_BUILD_DIR)
role="${1:-}"
: "${RIG:?RIG must name the rig file}"
HOSTS="${HOSTS:-4}"; COMPOSITOR="${COMPOSITOR:-127.0.0.1}"; VIEWER="${VIEWER:-127.0.0.1}"
REQUESTS="${REQUESTS:-239.255.42.1}"; CLOCK_PORT="${CLOCK_PORT:-5300}"
REQUEST_PORT="${REQUEST_PORT:-5000}"; FRAGMENT_PORT="${FRAGMENT_PORT:-5200}"
VIDEO_PORT="${VIDEO_PORT:-5100}"; FPS="${FPS:-15}"; ENCODING="${ENCODING:-jpeg}"
QUALITY="${QUALITY:-90}"; LATENCY_MS="${LATENCY_MS:-40}"; LOSS="${LOSS:-0}"
VIEW="${VIEW:-orbit=0.6 dolly=15 path-frames=120 width=640 height=480}"
PHASE_NS="${PHASE_NS:-$((500000000 / FPS))}"; OUTPUT="${OUTPUT:-fakesink}"
export GST_PLUGIN_PATH="$build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
rtp_caps="application/x-rtp,media=application,clock-rate=90000,encoding-name=X-GST"
jpeg_caps="application/x-rtp,media=video,clock-rate=90000,encoding-name=JPEG,payload=26"
SRTP_KEY="${SRTP_KEY:-}"; INSECURE="${INSECURE:-0}"
if [ "$INSECURE" != 0 ] && [ "$INSECURE" != 1 ]; then
  echo "net-host.sh: INSECURE must be 0 or 1" >&2; exit 2
fi
if [ -n "$SRTP_KEY" ] && ! [[ "$SRTP_KEY" =~ ^[0-9a-fA-F]{60}$ ]]; then
  echo "net-host.sh: SRTP_KEY must be 60 hex digits (30 bytes: AES-128 key + salt)" >&2; exit 2
fi
if [ -n "$SRTP_KEY" ] && [ "$INSECURE" = 1 ]; then
  echo "net-host.sh: give one of SRTP_KEY and INSECURE=1" >&2; exit 2
fi
if [ "$INSECURE" = 0 ] && { [ "${RTX:-0}" = 1 ] || [ -n "${BASELINE:-}" ]; }; then
  echo "net-host.sh: RTX=1 and BASELINE send plain RTP (srtpdec knows each stream's own SSRC" \
    "only, not its retransmissions'; the baseline streams stock RTP/JPEG): add INSECURE=1," \
    "on a trusted network only" >&2; exit 2
fi
# Authenticated by default: the compositor host (started first, it prints
# the base time too) makes the session's key; the other hosts must be given it.
if [ -z "$SRTP_KEY" ] && [ "$INSECURE" = 0 ]; then
  case "$role" in
    compositor)
      SRTP_KEY=$(head -c 30 /dev/urandom | od -An -tx1 | tr -d ' \n')
      echo "srtp-key $SRTP_KEY"
      echo "net-host.sh: give every other host SRTP_KEY=$SRTP_KEY (a fresh key for this session;" \
        "INSECURE=1 everywhere for plain RTP on a trusted network)" >&2
      ;;
    camera | viewer)
      echo "net-host.sh: SRTP_KEY is not set: give this host the key the compositor host printed" \
        "(\"srtp-key HEX\"), or INSECURE=1 on every host for plain RTP on a trusted network" >&2
      exit 2
      ;;
  esac
fi
SSRC_REQUESTS=4096; SSRC_FRAGMENTS=8192; SSRC_VIDEO=12288; SSRC_RTX=16384
srtp_params="srtp-key=(buffer)$SRTP_KEY,srtp-cipher=(string)aes-128-icm,srtp-auth=(string)hmac-sha1-80"
srtp_params+=",srtcp-cipher=(string)aes-128-icm,srtcp-auth=(string)hmac-sha1-80,roc=(uint)0"
# receive CAPS SSRC: a udpsrc's caps and what follows it, up to the depayloader.
receive() {
  if [ -z "$SRTP_KEY" ]; then echo "caps=\"$1\""; return; fi
  local caps="${1/application\/x-rtp/application/x-srtp}"
  if [[ "$caps" != *payload=* ]]; then caps+=",payload=(int)96"; fi  # rtpgstpay's
  echo "caps=\"$caps,ssrc=(uint)$2,$srtp_params\" ! srtpdec"
}
# protect: what follows a payloader, before the sender.
protect() { if [ -n "$SRTP_KEY" ]; then echo "srtpenc key=$SRTP_KEY ! "; fi; }
# Forward error correction (FEC percent): fec_send PERCENT before protect;
# fec_receive after receive_ssrc, before the depayloader, whose caps carry
# the stream's SSRC (rtpulpfecdec needs it).
FEC="${FEC:-0}"; FEC_LATENCY_MS="${FEC_LATENCY_MS:-30}"; FEC_PT=122
REQUEST_FEC_LATENCY_MS="${REQUEST_FEC_LATENCY_MS:-5}"
if ! [[ "$FEC" =~ ^[0-9]+$ ]] || [ "$FEC" -gt 100 ]; then
  echo "net-host.sh: FEC must be a percentage, 0..100" >&2; exit 2
fi
if [ "$FEC" != 0 ] && [ -z "$SRTP_KEY" ]; then
  echo "net-host.sh: warning: FEC without SRTP_KEY: forged packets carrying a stream's SSRC" \
    "upset its jitter buffer and can stop the output; set SRTP_KEY on an untrusted network" >&2
fi
# Retransmission (RTX=1) of the fragments instead: see the header. The
# jitter buffer asks 1 ms after it sees a gap, again every 4 ms while the
# packet can still make it; the rtpsessions may send RTCP every 10 ms.
RTX="${RTX:-0}"; RTX_LATENCY_MS="${RTX_LATENCY_MS:-60}"; RTX_KEEP_MS="${RTX_KEEP_MS:-200}"
NACK_PORT="${NACK_PORT:-5400}"; RTX_PT=97
if [ "$RTX" != 0 ] && [ "$RTX" != 1 ]; then echo "net-host.sh: RTX must be 0 or 1" >&2; exit 2; fi
for v in RTX_LATENCY_MS RTX_KEEP_MS NACK_PORT FEC_LATENCY_MS REQUEST_FEC_LATENCY_MS; do
  if ! [[ "${!v}" =~ ^[0-9]+$ ]] || [ "${!v}" -lt 1 ] || [ "${!v}" -gt 65535 ]; then
    echo "net-host.sh: $v must be a whole number, 1..65535" >&2; exit 2
  fi
done
rtx_timers="rtx-delay=1 rtx-retry-timeout=4 rtx-min-retry-timeout=2"
if [ "$RTX" = 1 ] && [ -z "$SRTP_KEY" ]; then
  echo "net-host.sh: warning: RTX without SRTP_KEY: forged packets carrying a stream's SSRC" \
    "upset its jitter buffer, and forged NACKs cost a camera host up to lf-launch's" \
    "--rtx-budget (25 %) more packets; use RTX only on a trusted network" >&2
fi
if [ "$RTX" = 1 ] && [ -n "$SRTP_KEY" ]; then
  echo "net-host.sh: RTX=1 with SRTP_KEY is not supported (srtpdec knows only each stream's" \
    "own SSRC, not its retransmission stream's); use FEC" >&2; exit 2
fi
if [ "$RTX" = 1 ] && [ "$FEC" != 0 ]; then
  echo "net-host.sh: give one of RTX=1 and FEC (the view requests get FEC 100 with RTX)" >&2; exit 2
fi
REQ_FEC=0
if [ "$FEC" != 0 ] || [ "$RTX" = 1 ]; then REQ_FEC=100; fi
# fec_send PERCENT: parity packets, PERCENT 0 for none.
fec_send() {
  if [ "$1" != 0 ]; then echo "rtpulpfecenc pt=$FEC_PT percentage=$1 multipacket=true ! "; fi
}
# fec_receive ON [LATENCY_MS]: the FEC receiver when ON is not 0, giving up
# on a lost packet after LATENCY_MS [FEC_LATENCY_MS].
fec_receive() {
  if [ "$1" = 0 ]; then return; fi
  local latency="${2:-$FEC_LATENCY_MS}"
  echo " ! rtpstorage size-time=$(((latency + 100) * 1000000))"\
    "! rtpjitterbuffer do-lost=true latency=$latency ! rtpulpfecdec pt=$FEC_PT"\
    "! rtpptdemux ignored-payload-types=\"<$FEC_PT>\""
}
# receive_ssrc CAPS SSRC: receive, with the stream's SSRC in the caps
# (rtpulpfecdec and the retransmission requests need it, and lf-launch drops
# every packet of another SSRC before the jitter buffers and depayloaders).
receive_ssrc() {
  local caps="$1"
  if [[ "$caps" != *payload=* ]]; then caps+=",payload=(int)96"; fi  # rtpgstpay's
  if [ -z "$SRTP_KEY" ]; then caps+=",ssrc=(uint)$2"; fi  # receive adds it with SRTP
  receive "$caps" "$2"
}
# RTCP feedback to camera host K: its address (the group, or the K-th of
# the fan-out list).
nack_host() {
  if [ "$multicast" = 1 ]; then echo "$REQUESTS"; return; fi
  local ips=(${REQUESTS//,/ })
  echo "${ips[$1]:?REQUESTS lists no camera host $1}"
}
rtx_session="rtp-profile=avpf rtcp-min-interval=10000000 bandwidth=100000000"
# Sender side of an RTP stream: optional emulated loss, never clock-synced
# (buffers leave when ready; the receivers' deadlines do the scheduling).
loss=""
if [ "$LOSS" != 0 ]; then loss="identity drop-probability=$LOSS silent=true ! "; fi
sender="sync=false async=false"
iface=""
if [ -n "${IFACE:-}" ]; then iface="multicast-iface=$IFACE"; fi
multicast=0
if [[ "$REQUESTS" =~ ^2(2[4-9]|3[0-9])\. ]]; then multicast=1; fi

BASELINE_PORT="${BASELINE_PORT:-6000}"
PARTIAL_SUMS="${PARTIAL_SUMS:-0}"; SUM_LATENCY_MS="${SUM_LATENCY_MS:-$((LATENCY_MS / 2))}"
if [ "$PARTIAL_SUMS" != 0 ] && [ "$PARTIAL_SUMS" != 1 ]; then
  echo "net-host.sh: PARTIAL_SUMS must be 0 or 1" >&2; exit 2
fi
if ! [[ "$SUM_LATENCY_MS" =~ ^[0-9]+$ ]]; then
  echo "net-host.sh: SUM_LATENCY_MS must be a whole number of ms" >&2; exit 2
fi
ids=$("$build/tools/lf-rig" --input "$RIG" --ids)
case "$role" in
  compositor)
    clock=(--clock-server "$CLOCK_PORT" --base-time "${BASE_TIME:-now+3000}")
    if [ -n "${BASELINE:-}" ]; then
      mkdir -p "$BASELINE"
      desc=""; i=0
      for id in $ids; do
        desc+="  udpsrc port=$((BASELINE_PORT + i)) buffer-size=4194304 caps=\"$jpeg_caps\""
        desc+=" ! rtpjpegdepay ! multifilesink location=$BASELINE/cam$id-%05d.jpg"
        i=$((i + 1))
      done
    else
      # Caps travel in band (rtpgstpay) from whoever sends to the fragment
      # ports, so the view size and rate are fixed here, not taken from them.
      w=$(sed -n 's/.*width=\([0-9]*\).*/\1/p' <<< "$VIEW"); h=$(sed -n 's/.*height=\([0-9]*\).*/\1/p' <<< "$VIEW")
      desc="lfcompositor name=comp rig=$RIG latency=$((LATENCY_MS * 1000000)) framerate=$FPS/1"
      desc+=" width=${w:-640} height=${h:-480}"
      desc+=" ! videoconvert ! video/x-raw,format=I420 ! jpegenc quality=$QUALITY"
      desc+=" ! rtpjpegpay ssrc=$SSRC_VIDEO ! $(fec_send "$FEC")$(protect)$loss"
      desc+="udpsink host=$VIEWER port=$VIDEO_PORT $sender"
      for ((k = 0; k < HOSTS; k++)); do
        desc+="  udpsrc port=$((FRAGMENT_PORT + k)) buffer-size=16777216"
        caps="$rtp_caps"
        if [ "$RTX" = 1 ]; then caps+=",rtx-ssrc=(uint)$((SSRC_RTX + k))"; fi  # lf-launch lets both in
        desc+=" $(receive_ssrc "$caps" $((SSRC_FRAGMENTS + k)))"
        if [ "$RTX" = 1 ]; then
          desc+=" ! rtx$k.recv_rtp_sink rtpsession name=rtx$k $rtx_session rtx$k.recv_rtp_src"
          desc+=" ! rtprtxreceive payload-type-map=\"application/x-rtp-pt-map,96=(uint)$RTX_PT\""
          desc+=" ! rtpjitterbuffer do-retransmission=true do-lost=true latency=$RTX_LATENCY_MS $rtx_timers"
        fi
        desc+="$(fec_receive "$FEC") ! rtpgstdepay ! queue max-size-buffers=0 max-size-bytes=0 max-size-time=1000000000"
        desc+=" ! comp.sink_$k"
        if [ "$RTX" = 1 ]; then
          mc=""
          if [ "$multicast" = 1 ]; then mc="auto-multicast=true ttl-mc=1 $iface"; fi
          desc+="  rtx$k.send_rtcp_src ! udpsink host=$(nack_host $k) port=$((NACK_PORT + k)) $mc $sender"
        fi
      done
    fi
    ;;
  camera)
    host="${2:?camera needs the host index K (0..HOSTS-1)}"
    clock=(--clock-client "$COMPOSITOR:$CLOCK_PORT" --base-time "${BASE_TIME:?BASE_TIME from the compositor host}")
    # RTX: NACKs only from the compositor host (by its sender address).
    if [ "$RTX" = 1 ]; then
      if [[ "$COMPOSITOR" =~ ^[0-9.]+$ || "$COMPOSITOR" == *:* ]]; then
        clock+=(--rtcp-from "$COMPOSITOR")
      else
        echo "net-host.sh: warning: COMPOSITOR is not an IP address: NACKs are taken from anyone" >&2
      fi
    fi
    if [ "$multicast" = 1 ]; then
      src="udpsrc address=$REQUESTS port=$REQUEST_PORT auto-multicast=true $iface"
    else
      src="udpsrc port=$REQUEST_PORT"
    fi
    # The cameras of this host: rig order i with i % HOSTS == K, or with
    # partial sums the K-th block of the grid.
    if [ "$PARTIAL_SUMS" = 1 ]; then
      owner=($("$build/tools/lf-rig" --input "$RIG" --hosts "$HOSTS"))
    fi
    mine=""; i=0; n=0
    for id in $ids; do
      k=$((i % HOSTS))
      if [ "$PARTIAL_SUMS" = 1 ]; then k=${owner[$i]}; fi
      if [ "$k" = "$host" ]; then mine+="${mine:+,}$i"; n=$((n + 1)); fi
      i=$((i + 1))
    done
    sums=""
    if [ "$PARTIAL_SUMS" = 1 ]; then
      sums=" partial-sums=true sum-latency=$((SUM_LATENCY_MS * 1000000))"
    fi
    # The requests' caps, as the viewer's lfviewrequest sets them, in the RTP
    # caps (base64, rtpgstpay's first caps version): rtpgstdepay starts from
    # them instead of dropping requests until the viewer's next in-band copy
    # (config-interval, a second), so a restarted host answers at once.
    # Padded with spaces to whole base64 quanta: no '=' in the caps string.
    vw=640 vh=480
    if [[ " $VIEW " =~ [[:space:]]width=([0-9]+) ]]; then vw=${BASH_REMATCH[1]}; fi
    if [[ " $VIEW " =~ [[:space:]]height=([0-9]+) ]]; then vh=${BASH_REMATCH[1]}; fi
    rc="application/x-lf-view-request, framerate=(fraction)$FPS/1, width=(int)$vw, height=(int)$vh"
    while [ $((${#rc} % 3)) != 0 ]; do rc+=" "; done
    req_caps="$rtp_caps,caps=(string)$(printf '%s' "$rc" | base64 -w0),capsversion=(string)0"
    # One request stream in, one fragment stream out (the lfcamerahost bin).
    desc="$src $(receive_ssrc "$req_caps" $SSRC_REQUESTS)$(fec_receive "$REQ_FEC" "$REQUEST_FEC_LATENCY_MS") ! rtpgstdepay"
    desc+=" ! lfcamerahost rig=$RIG cameras=$mine is-live=true framerate=$FPS/1 phase=$PHASE_NS frame-select=capture-time"
    desc+=" encoding=$ENCODING jpeg-quality=$QUALITY$sums"
    desc+=" ! rtpgstpay config-interval=1 ssrc=$((SSRC_FRAGMENTS + host)) ! $(fec_send "$FEC")"
    if [ "$RTX" = 1 ]; then
      desc+="rtprtxsend payload-type-map=\"application/x-rtp-pt-map,96=(uint)$RTX_PT\""
      desc+=" ssrc-map=\"application/x-rtp-ssrc-map,$((SSRC_FRAGMENTS + host))=(uint)$((SSRC_RTX + host))\""
      desc+=" max-size-time=$RTX_KEEP_MS ! rtx.send_rtp_sink rtpsession name=rtx $rtx_session rtx.send_rtp_src ! "
    fi
    desc+="$(protect)$loss"
    desc+="udpsink host=$COMPOSITOR port=$((FRAGMENT_PORT + host)) $sender"
    if [ "$RTX" = 1 ]; then
      if [ "$multicast" = 1 ]; then
        desc+="  udpsrc address=$REQUESTS port=$((NACK_PORT + host)) auto-multicast=true $iface"
      else
        desc+="  udpsrc port=$((NACK_PORT + host))"
      fi
      desc+=" caps=application/x-rtcp ! rtx.recv_rtcp_sink"
    fi
    if [ -n "${BASELINE:-}" ]; then
      desc=""; i=0
      for id in $ids; do
        if [ $((i % HOSTS)) = "$host" ]; then
          desc+="  lfcamsrc rig=$RIG camera-id=$id is-live=true framerate=$FPS/1 phase=$PHASE_NS"
          desc+=" ! videoconvert ! video/x-raw,format=I420 ! jpegenc quality=$QUALITY ! rtpjpegpay ! $loss"
          desc+="udpsink host=$COMPOSITOR port=$((BASELINE_PORT + i)) $sender"
        fi
        i=$((i + 1))
      done
    fi
    if [ "$n" = 0 ]; then echo "net-host.sh: camera host $host serves no camera of $RIG" >&2; exit 2; fi
    ;;
  viewer)
    clock=(--clock-client "$COMPOSITOR:$CLOCK_PORT" --base-time "${BASE_TIME:?BASE_TIME from the compositor host}")
    if [ "$multicast" = 1 ]; then
      dest="udpsink host=$REQUESTS port=$REQUEST_PORT auto-multicast=true ttl-mc=1 $iface $sender"
    else
      clients=""
      for ip in ${REQUESTS//,/ }; do clients+="${clients:+,}$ip:$REQUEST_PORT"; done
      dest="multiudpsink clients=$clients $sender"
    fi
    # The compositor is on another host: its focal-surface answers cannot
    # come back here, so the viewer focuses on its focal plane (VIEW).
    desc="lfviewrequest rig=$RIG is-live=true framerate=$FPS/1 focal-surface=false $VIEW"
    desc+=" ! rtpgstpay config-interval=1 ssrc=$SSRC_REQUESTS ! $(fec_send "$REQ_FEC")$(protect)$loss$dest"
    desc+="  udpsrc port=$VIDEO_PORT buffer-size=4194304 $(receive_ssrc "$jpeg_caps" $SSRC_VIDEO)"
    desc+="$(fec_receive "$FEC") ! rtpjpegdepay ! jpegdec ! $OUTPUT"
    ;;
  *)
    echo "usage: net-host.sh compositor | camera K | viewer   (settings: see the script's header)" >&2
    exit 2
    ;;
esac
cmd=("$build/tools/lf-launch" "${clock[@]}")
# FEC: the jitter buffers learn the parity packets' clock rate (else they
# drop them and wait out their latency for each gap).
if [ "$REQ_FEC" != 0 ]; then cmd+=(--rtp-clock-rate "$FEC_PT=90000"); fi
if [ -n "${DURATION:-}" ]; then cmd+=(--duration "$DURATION"); fi
if [ "${PRINT:-0}" = 1 ]; then
  printf '%q ' "${cmd[@]}" --; echo "$desc"
  exit 0
fi
exec "${cmd[@]}" -- "$desc"
