#!/bin/bash
# The GL backend on a lent GPU machine (issue 38, item 5): such a machine
# (this workplace's `device` tool) runs another Linux with no Debian
# packages and no network, so this bundles what the run needs into .gpu/
# (git-ignored through .git/info/exclude): the benches and test_gl, the
# plugin, the shared libraries they load (Debian 12's, glibc and libstdc++
# aside), GStreamer's core elements and appsink, and the Chess 8x8 block
# as JPEG q85 (the PNGs are too large to carry). The device run is then
#   bash .gpu/run.sh            (with .gpu carried; output in $OUT)
# which uses the NVIDIA driver's EGL (EGL device platform) and prints
# test_gl (GL against the CPU kernels), lf-gst-bench at 1080p and 4K
# (cpu and gl rows, PSNR of the gl frame against the cpu one), lf-bench's
# whole views with GL's time split, and traces of live 1080p runs.
# `scripts/gpu-bench.sh --record DIR` writes DIR's machine.txt, test_gl.txt
# and bench.txt into docs/results/gpu.md, which scripts/bench.sh quotes.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
if [ "${1:-}" = --record ]; then
  d="$2"; out=docs/results/gpu.md
  {
    echo "Recorded $(date -u '+%Y-%m-%d') from \`bash .gpu/run.sh\` (bundle made by \`scripts/gpu-bench.sh\` at commit $(git rev-parse --short HEAD)) on a lent machine:"
    echo
    echo '```'
    cat "$d/machine.txt"
    echo '```'
    echo
    echo "GL against the CPU kernels (\`test_gl --gtest_filter=GlBackend.*\`, synthetic 4x4 rig):"
    echo
    echo '```'
    grep -E "^GL:|differ|PASSED|FAILED" "$d/test_gl.txt"
    echo '```'
    echo
    frames=$(sed -n 's/.*(non-live, \([0-9]*\) requests).*/\1/p' "$d/bench.txt" | head -1)
    echo "\`lf-gst-bench --input data/chess64.json --sizes 1920x1080,3840x2160 --encodings raw --backends cpu,gl --frames ${frames:-100}\` (64 cameras; the CPU rows use the machine's cores, the GL rows one thread and the GPU):"
    echo
    grep -v "^Kernel bound" "$d/bench.txt" | sed -n '/^| output/,$p'
    if [ -f "$d/split.txt" ]; then
      echo
      how=$(sed -n 's/^## Backends: whole views from 64 cameras, //p' "$d/split.txt")
      echo "Whole views from the 64 cameras, GL against the CPU renderer on every core, and where GL's time goes (\`lf-bench --input data/chess64.json --sizes 1920x1080,3840x2160 --skip-quality --skip-bandwidth --skip-speed --backend cpu,gl\`; ${how:-8 views}):"
      echo
      sed -n '/^CPU: /p' "$d/split.txt"
      echo
      sed -n '/^| size/,$p' "$d/split.txt"
    fi
    if [ -f "$d/gl.trace" ]; then
      echo
      echo "Where a live 1080p frame's time goes (150 requests at 30 a second, \`LF_TRACE\` read by \`tools/lf-trace\`; ms, median and p95):"
      echo
      echo "| backend | composite (add + resolve + read back) | round trip (issued -> composited) |"
      echo "|---|---|---|"
      for b in cpu gl; do
        t=$(build/tools/lf-trace "$d/$b.trace" 2>/dev/null)
        c=$(awk -F'|' '/^\| composite/ {gsub(/ /, ""); print $3 ", " $4}' <<< "$t")
        r=$(awk -F'|' '/round trip\*\* \(issued/ {gsub(/ /, ""); print $3 ", " $4}' <<< "$t")
        echo "| $b | $c | $r |"
      done
    fi
  } > "$out"
  echo "wrote $out"
  exit 0
fi
[ -x build/tools/lf-gst-bench ] || { echo "build first: scripts/setup.sh" >&2; exit 1; }
data="${DATA:-$root/../shared/data}/stanford-chess"
g=.gpu; rm -rf "$g"; mkdir -p "$g/b/lib" "$g/b/bin" "$g/b/plugins" "$g/b/lf" "$g/data"
mkdir -p .git/info; grep -qs '^/.gpu/' .git/info/exclude || echo /.gpu/ >> .git/info/exclude
plugins=/usr/lib/x86_64-linux-gnu/gstreamer-1.0
scanner=/usr/lib/x86_64-linux-gnu/gstreamer1.0/gstreamer-1.0/gst-plugin-scanner
bins=(build/tools/lf-gst-bench build/tools/lf-bench build/tests/test_gl)
# lf-bench links OpenCV's image codecs, which load GDAL, GDCM and OpenEXR
# (and 150 MB of their dependencies): stubs that abort if called stand in
# for those four (the run reads JPEG only); the codecs library is linked
# BIND_NOW, so each stub defines every symbol it takes from the real one.
codecs=$(ldd build/tools/lf-bench | awk '/libopencv_imgcodecs/ {print $3}')
objdump -T "$codecs" | awk '/\*UND\*/ {print $NF}' | sort -u > "$g/und"
for l in libgdal.so.32 libgdcmMSFF.so.3.0 libgdcmDSED.so.3.0 libOpenEXR-3_1.so.30; do
  real=$(ldd "$codecs" | awk -v l="$l" '$1 == l {print $3}')
  { echo '#include <stdlib.h>'
    nm -D --defined-only "$real" | awk '{print $NF}' | sort -u | comm -12 - "$g/und" |
      sed 's/.*/void &(void) { abort(); }/'; } > "$g/stub.c"
  gcc -shared -fPIC -w -o "$g/b/lib/$l" -Wl,-soname,"$l" "$g/stub.c"
done
rm -f "$g/und" "$g/stub.c"
for b in "${bins[@]}" build/gst/libgstlightfield.so "$plugins/libgstcoreelements.so" \
         "$plugins/libgstapp.so" "$scanner"; do
  LD_LIBRARY_PATH="$g/b/lib:build/lib" ldd "$b"
done | awk '/=>/ {print $3}' | sort -u |
  grep -v -E "/(libc|libm|libpthread|libdl|librt|libresolv|libstdc\+\+|libgcc_s)\.so|^$g/" |
  while read -r l; do cp -L "$l" "$g/b/lib/"; done
cp "${bins[@]}" "$scanner" /usr/bin/gst-launch-1.0 "$g/b/bin/"
cp "$plugins/libgstcoreelements.so" "$plugins/libgstapp.so" "$g/b/plugins/"
cp build/gst/libgstlightfield.so "$g/b/lf/"
strip "$g/b/bin/lf-gst-bench" "$g/b/bin/lf-bench" "$g/b/bin/test_gl" "$g/b/lf/libgstlightfield.so"
(cd "$g/b" && tar cf - lib bin plugins lf | xz -T0 -6 > ../bundle.tar.xz)
rm -rf "$g/b"
# The Chess 8x8 block, as JPEG.
build/tools/lf-rig --input "$data" --block 0,0,8,8 --out "$g/data/chess64.json" > /dev/null
python3 - "$g/data/chess64.json" "$data" <<'PY'
import json, os, subprocess, sys
path, data = sys.argv[1], sys.argv[2]
rig = json.load(open(path))
for c in rig["cameras"]:
    src = os.path.join(data, os.path.basename(c["image"]))
    c["image"] = os.path.basename(src)[:-4] + ".jpg"
    subprocess.check_call(["gst-launch-1.0", "-q", "filesrc", "location=" + src, "!", "pngdec", "!",
                           "videoconvert", "!", "jpegenc", "quality=85", "!", "filesink",
                           "location=" + os.path.join(os.path.dirname(path), c["image"])])
json.dump(rig, open(path, "w"), indent=1)
PY
cat > "$g/run.sh" <<'RUN'
#!/bin/bash
# On the lent machine, from the repository root with .gpu carried.
cd "$(dirname "$0")"
OUT=${OUT:-/tmp/out}; mkdir -p "$OUT" /tmp/b
tar xJf bundle.tar.xz -C /tmp/b 2>/dev/null ||
  python3 -c "import tarfile; tarfile.open('bundle.tar.xz').extractall('/tmp/b')"
export LD_LIBRARY_PATH=/tmp/b/lib:/usr/local/nvidia/lib64:/usr/local/nvidia/lib
export GST_PLUGIN_SYSTEM_PATH=/tmp/b/plugins GST_PLUGIN_PATH=/tmp/b/lf
export GST_PLUGIN_SCANNER=/tmp/b/bin/gst-plugin-scanner GST_REGISTRY=/tmp/b/reg.bin
V=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f $V ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$V
{ nvidia-smi -L; echo "$(nproc) cores: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
  echo "EGL vendor: ${__EGL_VENDOR_LIBRARY_FILENAMES:-the system default}"; } 2>&1 | tee "$OUT/machine.txt"
timeout "${GL_T:-150}" /tmp/b/bin/test_gl --gtest_filter='GlBackend.*' 2>&1 | tee "$OUT/test_gl.txt" |
  grep -E "^GL:|OK|FAILED|PASSED|differ|Failure"
timeout "${BENCH_T:-330}" /tmp/b/bin/lf-gst-bench --input data/chess64.json \
  --sizes "${SIZES:-1920x1080,3840x2160}" --encodings raw --backends "${BACKENDS:-cpu,gl}" \
  --frames "${FRAMES:-100}" 2>&1 | tee "$OUT/bench.txt"
# Whole views, GL against the CPU on all cores, GL's time split.
timeout "${SPLIT_T:-120}" /tmp/b/bin/lf-bench --input data/chess64.json --sizes 1920x1080,3840x2160 \
  --skip-quality --skip-bandwidth --skip-speed --backend cpu,gl 2>&1 | tee "$OUT/split.txt"
# Where a live 1080p frame's time goes, per backend: LF_TRACE files for
# tools/lf-trace (read back on the build machine).
for b in cpu gl; do
  LF_TRACE="$OUT/$b.trace" timeout 60 /tmp/b/bin/gst-launch-1.0 -q lfviewrequest \
    rig=data/chess64.json width=1920 height=1080 orbit=0.5 focal-surface=false framerate=30/1 \
    is-live=true num-buffers=150 ! lfarray rig=data/chess64.json num-buffers=1 max-rate=0 \
    backend=$b latency=100000000 ! fakesink sync=false
done
RUN
chmod +x "$g/run.sh"
echo "$g: $(du -sh "$g" | cut -f1) to carry; on the lent machine: bash .gpu/run.sh"
