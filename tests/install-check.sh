#!/usr/bin/env bash
# Embedding (issue 14): installs the build into a temporary root (meson
# install --destdir), then, only from what was installed:
#  1. builds docs/examples/core.cpp against the installed pkg-config file
#     lightfield-1.0 (the core alone, no GStreamer) and runs it;
#  2. builds docs/examples/steer.c (C, GStreamer) and runs it with the
#     installed plugin: a property change, the lf-view event and a
#     GstController move, checked from what lfviewrequest reports back;
#  3. runs docs/examples/steer.py (Python, PyGObject) the same way.
# usage: install-check.sh BUILD_DIR
set -euo pipefail
build="$(cd "$1" && pwd)"
root="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
meson install -C "$build" --no-rebuild --destdir "$work/root" --quiet > "$work/install.log"
pc="$(find "$work/root" -name lightfield-1.0.pc | head -1)"
plugin="$(find "$work/root" -name libgstlightfield.so | head -1)"
core_lib="$(find "$work/root" -name 'liblightfield-1.0.so' | head -1)"
[ -n "$pc" ] && [ -n "$plugin" ] && [ -n "$core_lib" ] || { echo "FAIL: install is missing the .pc, plugin or library"; exit 1; }
echo "ok: installed $(basename "$core_lib"), $(basename "$pc"), $(basename "$plugin")"
# The .pc file as installed, its prefix moved under the temporary root.
prefix="$(sed -n 's/^prefix=//p' "$pc")"
mkdir -p "$work/pc"
sed "s|^prefix=.*|prefix=$work/root$prefix|" "$pc" > "$work/pc/lightfield-1.0.pc"
export PKG_CONFIG_PATH="$work/pc"
export LD_LIBRARY_PATH="$(dirname "$core_lib")"
fail=0
# 1. The core alone.
c++ -std=c++17 "$root/docs/examples/core.cpp" $(pkg-config --cflags --libs lightfield-1.0) -o "$work/core"
if ldd "$work/core" | grep -q gstreamer; then echo "FAIL: the core example links GStreamer"; fail=1; fi
out=$("$work/core" "$work/core.png")
echo "$out"
if [[ "$out" =~ ^view\ 320x240,\ ([0-9]+)\ of\ 76800 ]] && [ "${BASH_REMATCH[1]}" -gt 70000 ]; then
  echo "ok: core example (pkg-config lightfield-1.0) rendered a view"
else
  echo "FAIL: core example"; fail=1
fi
# 2. and 3. The plugin embedded in C and in Python, steering while playing.
rig="$work/rig.json"
"$build/tools/lf-rig" --synthetic 4x4 --spacing 0.05 --size 160x120 --out "$rig" > /dev/null
export GST_PLUGIN_PATH="$(dirname "$plugin")" GST_REGISTRY="$work/registry.bin"
cc "$root/docs/examples/steer.c" $(pkg-config --cflags --libs gstreamer-1.0 gstreamer-app-1.0 gstreamer-controller-1.0) -o "$work/steer"
check_steer() {  # check_steer NAME OUTPUT
  local name="$1" out="$2"
  if grep -qx "eye-s 0.01" <<< "$out" && grep -qx "focal-depth 2.5" <<< "$out" &&
    grep -qx "refused focal-dept" <<< "$out" &&
    grep -qx "frames 60" <<< "$out" &&
    awk '$1=="eye-t"{n++; if ($3 < prev - 1e-12 || $3 < 0 || $3 > 0.02 + 1e-12) bad=1; prev=$3; last=$3}
         END{exit !(n >= 25 && !bad && last > 0.015)}' <<< "$out"; then
    echo "ok: $name example steered the view while playing (property, lf-view event by view-event and a bad one refused, GstController move)"
  else
    echo "FAIL: $name example"; echo "$out" | head -20; fail=1
  fi
}
check_steer C "$(timeout 60 "$work/steer" "$rig" synthetic 60)"
check_steer Python "$(timeout 60 /usr/bin/python3 "$root/docs/examples/steer.py" "$rig" synthetic 60)"
exit $fail
