#!/usr/bin/env bash
# N views in one request round (a quilt request) against N independent
# viewers of the same eyes, through one camera host (lfcamerahost, 64 Chess
# cameras), live at a rate both keep up with, side by side in one run: CPU
# time per frame (the process's, over the frames asked for), fragment bytes
# per frame (the camera host's output, written to a file) and request bytes
# per frame. The viewers' requests join in a `funnel`, as lf-web joins its
# viewers' (the camera host takes them in turn, lfrequestqueue). One early
# run through lfrequestmux produced no frame in 30 s; 8 later runs of the
# same line finished in 4 s each (not understood). Not live, lfrequestmux
# can stall: its known limit, gst/lfrequestmux.cpp.
#
# usage: scripts/quilt-bench.sh [VIEWS COLS ROWS TILE_W TILE_H [FRAMES [RUNS [FPS]]]]
#   defaults: 48 8 6 240 180 20 3 5/1
# The independent viewers' eyes are the quilt's eye positions with parallel
# axes (lfviewrequest has no lens-shift property), the same tile size and
# focal plane: the same pixels to warp, composite and send.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"
views="${1:-48}" cols="${2:-8}" rows="${3:-6}" tw="${4:-240}" th="${5:-180}"
frames="${6:-20}" runs="${7:-3}" fps="${8:-5/1}"
export GST_PLUGIN_PATH="$build/gst"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
rig="$tmp/chess64.json"
"$build/tools/lf-rig" --input "$root/../shared/data/stanford-chess" --block 0,0,8,8 --out "$rig" >/dev/null
focal="focal-plane=param:-0.25"
# The quilt's baseline: the array's width along x (the default view looks
# along the camera plane's normal, its x axis the plane's s axis, so eye i
# of the quilt is the default eye moved by eye-s).
extent="$(python3 - "$rig" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
xs = [c["t"][0] for c in r["cameras"]]  # R = I in this rig: centre = -t
print(max(xs) - min(xs))
PY
)"
measure() {  # name, then the pipeline's arguments
  local name="$1"; shift
  # CPU and bytes from a quiet run; the frames out from a second, verbose
  # one (each fakesink's "chain" message, silent=false: printing them costs
  # CPU, so the first run does not).
  /usr/bin/time -f "%e %U %S" -o "$tmp/time" timeout 60 gst-launch-1.0 -q "$@" >/dev/null \
    2>"$tmp/err" || { echo "$name: failed or timed out"; return; }
  local bytes; bytes=$(stat -c %s "$tmp/fragments.bin")
  local out=0 verbose=() a
  for a in "$@"; do
    verbose+=("$a")
    [ "$a" = fakesink ] && verbose+=(silent=false)
  done
  timeout 60 gst-launch-1.0 -v "${verbose[@]}" >"$tmp/out" 2>&1 &&
    out=$(grep -c "last-message = chain" "$tmp/out")
  read -r wall user sys <"$tmp/time"
  python3 - "$name" "$wall" "$user" "$sys" "$bytes" "$frames" "$out" <<'PY'
import sys
name, wall, u, s, b, n, out = sys.argv[1], *map(float, sys.argv[2:6]), int(sys.argv[6]), sys.argv[7]
print(f"{name}: wall {wall:.2f} s, CPU {(u + s) / n * 1000:.0f} ms and fragments "
      f"{b / n / 1e6:.2f} MB per quilt's worth of views; frames out {out} (in a second run)")
PY
}
quilt_line() {
  echo lfviewrequest rig="$rig" width=$((tw * cols)) height=$((th * rows)) quilt-views="$views" \
    quilt-columns="$cols" quilt-rows="$rows" quilt-baseline="$extent" $focal num-buffers="$frames" \
    focal-surface=false is-live=true framerate=$fps ! lfcamerahost rig="$rig" is-live=true ! tee name=t \
    t. ! queue ! filesink async=false location="$tmp/fragments.bin" \
    t. ! queue ! lfcompositor rig="$rig" ! fakesink async=false
}
# The sinks do not preroll (async=false), as no live sink needs to: with
# 48 live viewers, each compositor's fakesink prerolling, the pipeline
# stalled in 4 runs of 4 on a 2-core AMD EPYC (about 34 of the 48 sinks
# waiting in preroll: a live pipeline plays once every sink has a frame,
# and the demux stopped behind the first full queue; docs/reliability.md),
# and ran to its end in 4 of 4 with async=false.
viewers_line() {
  local line="funnel name=reqs ! lfcamerahost rig=$rig is-live=true ! tee name=t"
  line+=" t. ! queue ! filesink async=false location=$tmp/fragments.bin t. ! queue ! lffragmentdemux name=d"
  for ((i = 0; i < views; i++)); do
    # eye i of the quilt: -extent/2 .. +extent/2 along the camera plane's s axis
    local s; s=$(python3 -c "print($extent * ($i / ($views - 1) - 0.5))")
    line+=" lfviewrequest viewer-id=$i rig=$rig width=$tw height=$th eye-s=$s $focal"
    line+=" num-buffers=$frames focal-surface=false is-live=true framerate=$fps ! reqs."
    line+=" d.src_$i ! queue ! lfcompositor viewer-id=$i rig=$rig ! fakesink async=false"
  done
  echo "$line"
}
echo "# $views views of ${tw}x${th} (quilt ${cols}x${rows}), 64 cameras, $frames frames, $(nproc) cores"
for ((r = 1; r <= runs; r++)); do
  # shellcheck disable=SC2046
  measure "run $r quilt (one request round)" $(quilt_line)
  # shellcheck disable=SC2046
  measure "run $r $views independent viewers" $(viewers_line)
done
echo "requests: $((152 + 16)) bytes per frame as a quilt, $((152 * views)) as $views viewers"
