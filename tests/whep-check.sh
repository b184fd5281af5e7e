#!/usr/bin/env bash
# lf-web's WHEP endpoint (RFC 9725) played by a WHEP client the project
# writes with webrtcbin (tests/web/whep-client.py: no lf-web signalling):
# refusals (415, 400, 404, PATCH 405), 201 with an SDP answer and a
# Location, frames decoded, the view steered over the data channel, DELETE
# 200 then 404; with --token, a player without it gets 401 and one with it
# plays; afterwards the server holds no viewer.
#
# usage: tests/whep-check.sh BUILD_DIR SHARED_DATA_DIR
set -euo pipefail
build="$1"; data="$2"
here="$(cd "$(dirname "$0")" && pwd)"
if [ ! -d "$data/stanford-chess" ]; then
  echo "whep: $data/stanford-chess is absent (scripts/get-data.sh): skipped"
  exit 77
fi
export GST_PLUGIN_PATH="$build/gst" GST_REGISTRY="$build/whep-registry.bin"
log="$(mktemp)"
server=""
trap '[ -n "$server" ] && kill "$server" 2>/dev/null; wait 2>/dev/null; rm -f "$log"' EXIT
start() {  # extra lf-web options
  : >"$log"
  "$build/tools/lf-web" --rig "$data/stanford-chess" --block 0,0,4,4 --input-scale 0.5 \
    --framerate 10 --port 0 --address 127.0.0.1 "$@" >"$log" 2>&1 &
  server=$!
  for _ in $(seq 600); do
    port=$(sed -n 's|.*open http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$log")
    [ -n "$port" ] && return 0
    kill -0 "$server" 2>/dev/null || { cat "$log"; echo "FAIL: lf-web exited"; exit 1; }
    sleep 0.1
  done
  echo "FAIL: lf-web printed no port within 60 s"; exit 1
}
stop() { kill "$server"; wait "$server" 2>/dev/null || true; server=""; }
fail=0
start
for view in default orbit; do
  if out=$(timeout 90 /usr/bin/python3 "$here/web/whep-client.py" \
      "http://127.0.0.1:$port/whep/$view" --frames 15 --timeout 30); then
    echo "ok: WHEP /whep/$view: $out"
  else
    echo "FAIL: WHEP /whep/$view: $out"; fail=1
  fi
done
sleep 1
grep -q "viewer 0 left: the WHEP player ended the session (DELETE) (0 viewers" "$log" &&
  echo "ok: the server holds no viewer after the DELETEs" ||
  { echo "FAIL: a viewer stayed after DELETE:"; cat "$log"; fail=1; }
stop
start --token s3cret
code=$(/usr/bin/python3 - "http://127.0.0.1:$port/whep/default" <<'PY'
import sys, urllib.error, urllib.request
req = urllib.request.Request(sys.argv[1], data=b"v=0\r\n", method="POST",
                             headers={"Content-Type": "application/sdp"})
try:
    print(urllib.request.urlopen(req, timeout=10).status)
except urllib.error.HTTPError as e:
    print(e.code)
PY
)
[ "$code" = 401 ] && echo "ok: a player without the token gets 401" ||
  { echo "FAIL: a player without the token got $code"; fail=1; }
if out=$(timeout 90 /usr/bin/python3 "$here/web/whep-client.py" \
    "http://127.0.0.1:$port/whep/default" --token s3cret --frames 5 --timeout 30); then
  echo "ok: WHEP with the token: $out"
else
  echo "FAIL: WHEP with the token: $out"; fail=1
fi
stop
exit "$fail"
