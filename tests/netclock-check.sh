#!/usr/bin/env bash
# Network clock: lf-launch publishes this machine's clock (GstNetTimeProvider)
# and a second process slaves a GstNetClientClock to it over UDP loopback;
# after synchronisation the clocks must agree within 5 ms (issue: "clocks
# agree within 5 ms after sync"): the median offset in the third second
# after sync (lf-launch --check-clock --clock-settle 2; a clock's first rate
# estimate on a busy machine drifts for a moment).
set -euo pipefail
build="$1"
port=$((20000 + RANDOM % 20000))
"$build/tools/lf-launch" --clock-server "$port" --base-time now+0 --duration 16 -- \
  fakesrc is-live=true ! fakesink > /dev/null &
server=$!
trap 'kill $server 2>/dev/null || true' EXIT
sleep 0.5
worst=0
for i in 1 2 3; do
  off=$("$build/tools/lf-launch" --clock-client 127.0.0.1:$port --sync-timeout 5 --check-clock --clock-settle 2 | awk '/clock-offset-ms/ {print $2}')
  [ -n "$off" ] || { echo "no clock offset reported" >&2; exit 1; }
  echo "client $i: clock offset $off ms"
  worst=$(awk -v a="$worst" -v b="$off" 'BEGIN { b = b < 0 ? -b : b; print (b > a ? b : a) }')
done
awk -v w="$worst" 'BEGIN { if (w >= 5.0) { print "clock offset " w " ms >= 5 ms"; exit 1 } }'
echo "network clock: worst offset $worst ms (< 5 ms)"
