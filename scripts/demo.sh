#!/usr/bin/env bash
# Sets everything up and runs the main job on the bundled real data: the
# GStreamer pipeline (1) over the Stanford "Chess" light field, 64 real
# cameras (an 8x8 block) along a camera path -> out/chess64.avi, plus an
# offline still with auto-focus -> out/chess-still.png.
# Without ../shared/data (a fresh clone on its own) it runs the same pipeline
# on the built-in synthetic dynamic scene -> out/synthetic.avi and says how to
# get the real data (scripts/get-data.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
# The build directory: $LF_BUILD_DIR (default ./build).
export LF_BUILD_DIR="${LF_BUILD_DIR:-$PWD/build}"
build="$LF_BUILD_DIR"
./scripts/setup.sh
mkdir -p out
if [ ! -d ../shared/data/stanford-chess ]; then
  echo "demo: ../shared/data/stanford-chess is absent: running the built-in synthetic dynamic scene instead"
  ./pipelines/synthetic.sh out/synthetic.avi 100
  echo "demo: wrote out/synthetic.avi (GStreamer pipeline, synthetic 6x6 array)."
  echo "demo: for the real 64-camera Chess run: scripts/get-data.sh (fetches the public datasets" \
    "into ../shared/data and checks their SHA-256 sums), then scripts/demo.sh again"
  exit 0
fi
./pipelines/chess64.sh out/chess64.avi 120
"$build/tools/lf-render" --input ../shared/data/stanford-chess --block 0,0,8,8 \
  --at -3320,-812 --size 640x480 --focal plane --out out/chess-still.png --quiet
# The same view through a focal surface (a plane per 16-pixel tile, a second
# at depth edges, the default): the near pieces and the board's edge sharp too.
"$build/tools/lf-render" --input ../shared/data/stanford-chess --block 0,0,8,8 \
  --at -3320,-812 --size 640x480 --out out/chess-still-surface.png --quiet
echo "demo: wrote out/chess64.avi (GStreamer pipeline), out/chess-still.png (lf-render, one" \
  "focal plane: --focal plane) and out/chess-still-surface.png (lf-render's default focal surface)"
