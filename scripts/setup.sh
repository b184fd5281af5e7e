#!/usr/bin/env bash
# Installs the Debian 12 packages the build needs (if missing), configures
# and builds lightfield-gst in ./build. Safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."
# The build directory: $LF_BUILD_DIR (default ./build).
export LF_BUILD_DIR="${LF_BUILD_DIR:-$PWD/build}"
build="$LF_BUILD_DIR"

PACKAGES=(g++ meson ninja-build pkg-config libopencv-dev libturbojpeg0-dev libpng-dev
          nlohmann-json3-dev libdeflate-dev zlib1g-dev libgtest-dev
          libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev gstreamer1.0-tools
          gstreamer1.0-plugins-base gstreamer1.0-plugins-good gstreamer1.0-plugins-bad
          python3-gst-1.0 gir1.2-gst-plugins-bad-1.0 valgrind iproute2
          libceres-dev cmake
          libsoup-3.0-dev libgstreamer-plugins-bad1.0-dev gstreamer1.0-nice
          libegl-dev libgles-dev libglm-dev libegl-mesa0 libgl1-mesa-dri)
./scripts/install-packages.sh "${PACKAGES[@]}"

if [ ! -f "$build/build.ninja" ]; then
  meson setup "$build" --buildtype=release
fi
ninja -C "$build"
