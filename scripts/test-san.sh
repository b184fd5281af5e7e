#!/usr/bin/env bash
# The sanitizer run: builds with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer (scripts/setup-san.sh), runs the in-process test
# programs (every test but the 'system' suite, whose tests launch other
# processes: valgrind, gst-launch, lf-launch), then each fuzz harness for
# SECONDS (default 60; scripts/fuzz.sh).
# usage: scripts/test-san.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
build="${LF_SAN_BUILD_DIR:-$PWD/build-san}"
./scripts/setup-san.sh "$build"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp"
# OpenCV's gphoto2 camera probing is of no use here and leaks (tests/lsan.supp).
export OPENCV_VIDEOIO_PRIORITY_GPHOTO2=0
# GStreamer (also through OpenCV's video I/O) sees only the plugin packages
# the tests use, in a registry of this run: with every installed plugin
# (plugins-bad) GLib passes 2048 quarks and leaks its first quark block on
# purpose (gquark.c), which LeakSanitizer's shallow stacks cannot tell from
# a real leak.
# The GStreamer test programs ask ASan for full malloc stacks
# (fast_unwind_on_malloc=0, tests/gst_init.h); llvmpipe's LLVM JIT registers
# its unwind tables under libgcc's unwinder lock and allocates there, and
# ASan's full unwind takes that lock again: a deadlock inside Mesa. So their
# GL tests (GlBackend*) run in the regular build only; the GL library runs
# under the sanitizers in test_gl (plain malloc stacks), and the elements'
# no-GL path in gst_harness_nogl. (Mesa's softpipe, which has no JIT, drew
# wrong pixels there: it is not a substitute.) A --gtest_filter on a test's
# command line takes precedence over this.
export GTEST_FILTER="-*GlBackend*"
export GST_PLUGIN_LOADING_WHITELIST="gstreamer:gst-plugins-base:gst-plugins-good:lightfield-gst"
export GST_REGISTRY="$build/san-registry.bin"
# Build the GStreamer registry once, outside the measured runs (in process:
# the plugin scanner cannot load a sanitized plugin).
ASAN_OPTIONS=detect_leaks=0 "$build/tests/test_gst_harness" \
  --gtest_filter=Harness.CamSrcCapsAndCaptureTime > /dev/null
rm -rf "$build/gtest-xml"
status=0
GTEST_OUTPUT=xml:"$build/gtest-xml/" meson test -C "$build" --no-suite system \
  --print-errorlogs --timeout-multiplier 3 || status=$?
./scripts/fuzz.sh "${1:-60}" "$build" || status=1
exit "$status"
