#!/usr/bin/env bash
# A sender restarted within an SRTP session (the same key and SSRC, its
# sequence numbers starting lower than where the first run stopped) is heard
# again through lf-launch, which resets a stream that stops authenticating
# while packets keep coming (tools/lf-launch.cpp, guard_srtp). A stock
# gst-launch-1.0 receiver beside it, for comparison, is printed: its
# srtpdec takes every packet of the restarted sender for a replay (0 of 40
# frames, measured on GStreamer 1.22).
# usage: srtp-restart-check.sh BUILD_DIR
set -euo pipefail
build="$(cd "$1" && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
key=$(head -c 30 /dev/urandom | od -An -tx1 | tr -d ' \n')
params="srtp-key=(buffer)$key,srtp-cipher=(string)aes-128-icm,srtp-auth=(string)hmac-sha1-80"
params+=",srtcp-cipher=(string)aes-128-icm,srtcp-auth=(string)hmac-sha1-80,roc=(uint)0"
port=$((20000 + $$ % 20000))
caps="application/x-srtp,media=application,clock-rate=90000,encoding-name=X-GST,payload=(int)96"
caps+=",ssrc=(uint)8193,$params"
# send FRAMES SEQNUM-OFFSET: one sender's run (64x48 frames over rtpgstpay).
send() {
  gst-launch-1.0 -q videotestsrc is-live=true num-buffers="$1" ! video/x-raw,width=64,height=48 \
    ! rtpgstpay ssrc=8193 seqnum-offset="$2" ! srtpenc key="$key" \
    ! udpsink host=127.0.0.1 port="$port"
}
fail=0
for receiver in lf-launch gst-launch; do
  mkdir -p "$work/$receiver"
  desc="udpsrc port=$port caps=\"$caps\" ! srtpdec ! rtpgstdepay ! multifilesink location=$work/$receiver/%05d.raw"
  if [ $receiver = lf-launch ]; then
    timeout 20 "$build/tools/lf-launch" --clock-server $((port + 1)) --duration 8 -- "$desc" \
      > "$work/$receiver.log" 2>&1 &
  else
    eval "timeout 8 gst-launch-1.0 -q $desc" > "$work/$receiver.log" 2>&1 &
  fi
  rx=$!
  sleep 1.5
  send 20 30000
  first=$(ls "$work/$receiver" | wc -l)
  sleep 0.5
  send 40 100  # restarted: sequence numbers far behind the first run's
  sleep 0.5
  total=$(ls "$work/$receiver" | wc -l)
  wait $rx || true
  echo "$receiver: first run $first of 20 frames, restarted sender $((total - first)) of 40"
  if [ $receiver = lf-launch ]; then
    if [ "$first" -ge 18 ] && [ $((total - first)) -ge 30 ]; then
      echo "ok: lf-launch hears the restarted sender"
    else
      echo "FAIL: lf-launch does not hear the restarted sender"; cat "$work/$receiver.log"; fail=1
    fi
    if ! grep -q "SRTP state is reset" "$work/$receiver.log"; then
      echo "FAIL: no reset reported"; fail=1
    fi
  fi
done
exit $fail
