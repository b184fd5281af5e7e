#!/usr/bin/env bash
# Sets everything up and runs the main job on the bundled real data: the
# Stanford "Chess" light field, an 8x8 block of 64 real cameras, rendered
# along a camera path (an orbit with a dolly through the camera plane) with
# auto-focus, to out/chess-orbit.avi plus a still out/chess-still.png.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
mkdir -p out
./build/tools/lf-render --input ../shared/data/stanford-chess --block 0,0,8,8 \
  --orbit 0.6 --dolly 15 --frames 90 --size 640x480 --focal auto \
  --out out/chess-orbit.avi "$@"
./build/tools/lf-render --input ../shared/data/stanford-chess --block 0,0,8,8 \
  --at -3320,-812 --size 640x480 --focal auto --out out/chess-still.png --quiet
echo "demo: wrote out/chess-orbit.avi and out/chess-still.png"
