#!/usr/bin/env bash
# A sender restarted within an SRTP session (the same master key and SSRC,
# its sequence numbers starting lower than where the first run stopped) is
# heard again through lf-launch, and encrypts under a key of its own start
# (tools/launch_srtp.h): the two runs send the same frames with the same
# sequence numbers and timestamps, and no packet of the second is the first
# run's ciphertext (with the master key used as is, every one was: keystream
# reuse). The receiver resets a stream that stops authenticating while
# packets keep coming, and answers srtpdec's request-key with the keys of
# the MKIs it hears.
# usage: srtp-restart-check.sh BUILD_DIR
set -euo pipefail
build="$(cd "$1" && pwd)"
work="$(mktemp -d)"
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true; rm -rf "$work"' EXIT
key=$(head -c 30 /dev/urandom | od -An -tx1 | tr -d ' \n')
params="srtp-key=(buffer)$key,srtp-cipher=(string)aes-128-icm,srtp-auth=(string)hmac-sha1-80"
params+=",srtcp-cipher=(string)aes-128-icm,srtcp-auth=(string)hmac-sha1-80,roc=(uint)0"
port=$((20000 + $$ % 20000))
caps="application/x-srtp,media=application,clock-rate=90000,encoding-name=X-GST,payload=(int)96"
caps+=",ssrc=(uint)8193,$params"
# send RUN FRAMES SEQNUM-OFFSET: one sender's run (64x48 frames over
# rtpgstpay, through lf-launch), its packets also captured in $work/capRUN.
send() {
  mkdir -p "$work/cap$1"
  gst-launch-1.0 -q udpsrc port=$((port + 2)) ! multifilesink location="$work/cap$1/%05d" &
  local cap=$!
  sleep 0.3
  "$build/tools/lf-launch" --clock-server $((port + 3)) -- videotestsrc is-live=true \
    num-buffers="$2" ! video/x-raw,width=64,height=48 ! rtpgstpay ssrc=8193 seqnum-offset="$3" \
    timestamp-offset=0 ! srtpenc key="$key" \
    ! multiudpsink clients=127.0.0.1:$port,127.0.0.1:$((port + 2)) > "$work/send$1.log" 2>&1
  sleep 0.2
  kill $cap 2>/dev/null || true
  wait $cap 2>/dev/null || true
}
fail=0
mkdir -p "$work/frames"
desc="udpsrc port=$port caps=\"$caps\" ! srtpdec ! rtpgstdepay ! multifilesink location=$work/frames/%05d.raw"
timeout 20 "$build/tools/lf-launch" --clock-server $((port + 1)) --duration 8 -- "$desc" \
  > "$work/receiver.log" 2>&1 &
rx=$!
pids+=($rx)
sleep 1.5
send 1 20 100
first=$(ls "$work/frames" | wc -l)
sleep 0.5
send 2 40 100  # restarted: the same sequence numbers and frames again
sleep 0.5
total=$(ls "$work/frames" | wc -l)
wait $rx || true
echo "first run $first of 20 frames, restarted sender $((total - first)) of 40"
if [ "$first" -ge 18 ] && [ $((total - first)) -ge 30 ]; then
  echo "ok: lf-launch hears the restarted sender"
else
  echo "FAIL: lf-launch does not hear the restarted sender"; cat "$work/receiver.log"; fail=1
fi
if ! grep -q "SRTP state is reset" "$work/receiver.log"; then
  echo "FAIL: no reset reported"; fail=1
fi
# Packets of the two runs with the same sequence number (bytes 2-3): their
# encrypted payloads (after the 12-byte header, before the 8-byte MKI and
# the 10-byte tag) must differ.
python3 - "$work/cap1" "$work/cap2" "$key" <<'EOF' || fail=1
import hashlib, hmac, os, sys
def packets(d):
    out = {}
    for f in sorted(os.listdir(d)):
        b = open(os.path.join(d, f), 'rb').read()
        if len(b) > 26:
            out[int.from_bytes(b[2:4], 'big')] = b
    return out
a, b = packets(sys.argv[1]), packets(sys.argv[2])
common = sorted(set(a) & set(b))
same = [s for s in common if a[s][12:-18] == b[s][12:-18]]
mki = {a[common[0]][-18:-10].hex(), b[common[0]][-18:-10].hex()} if common else set()
print(f"{len(common)} sequence numbers sent by both runs, {len(same)} with the same ciphertext; "
      f"MKIs {sorted(mki)}")
if len(common) < 10 or same or len(mki) != 2:
    print("FAIL: the restarted sender reused the first run's keystream (or too few packets to tell)")
    sys.exit(1)
# Each MKI is a nonce and its tag, HMAC-SHA256(master, label || nonce)[:4]
# (tools/launch_srtp.h), which a receiver checks before following it.
master = bytes.fromhex(sys.argv[3])
for m in map(bytes.fromhex, mki):
    if hmac.new(master, b"lightfield-gst srtp mki" + m[:4], hashlib.sha256).digest()[:4] != m[4:]:
        print(f"FAIL: MKI {m.hex()} is not tagged as launch_srtp.h says")
        sys.exit(1)
print("ok: the restarted sender encrypts under a key of its own")
EOF
exit $fail
