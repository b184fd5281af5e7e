#!/usr/bin/env bash
# Configures and builds the sanitizer build (clang, AddressSanitizer +
# UndefinedBehaviorSanitizer, libFuzzer instrumentation and harnesses) in
# BUILD_DIR (default build-san), installing clang and its runtime if missing.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-${LF_SAN_BUILD_DIR:-$PWD/build-san}}"
PACKAGES=(clang-14 libclang-rt-14-dev)
./scripts/install-packages.sh "${PACKAGES[@]}"
if [ ! -f "$build/build.ninja" ]; then
  CXX=clang++-14 CC=clang-14 meson setup "$build" --buildtype=debugoptimized \
    -Db_sanitize=address,undefined -Db_lundef=false -Dfuzzing=true > /dev/null
fi
ninja -C "$build"
