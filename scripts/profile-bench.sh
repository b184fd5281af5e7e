#!/usr/bin/env bash
# Where the in-process pipeline's CPU goes (issue 38, item 2): perf samples
# of lf-gst-bench (64 Chess cameras, raw fragments, the focal plane,
# non-live throughput then the live latency run) at 640x480 and 1920x1080,
# and with JPEG fragments (q90) at 640x480, grouped by what the code does:
# the warp kernels, adding and resolving the fragments, JPEG coding (the
# codec, the fragments' JPEG framing and decoding into the raw format),
# planning, copies and fills, allocation, threads and hand-offs
# (locks, wake-ups, the scheduler, TBB's pool), GStreamer and GLib, and
# start-up (libraries, image decoding). Shares are of all CPU samples of
# the process, every thread, user and kernel. Prints a markdown section;
# scripts/bench.sh keeps it in docs/results/profile.md and quotes it.
# Needs perf (Debian: linux-perf) and perf_event_paranoid <= 2.
# usage: scripts/profile-bench.sh [FRAMES_640 [FRAMES_1080]]   (default 1500 and 300)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${LF_BUILD_DIR:-$root/build}"
data="${DATA:-$root/../shared/data}/stanford-chess"
f640="${1:-1500}"; f1080="${2:-300}"
command -v perf > /dev/null || { echo "profile-bench: needs perf (apt-get install linux-perf)" >&2; exit 1; }
export GST_PLUGIN_PATH="$build/gst"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
echo "Machine: $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1), $(nproc) cores."
echo "Each column: \`perf record -F 999 -- build/tools/lf-gst-bench --input ../shared/data/stanford-chess --sizes SIZE --encodings ENC --frames N --skip-bound\`"
echo "(N = $f640 at 640x480, $f1080 at 1920x1080), then \`perf report --no-children --sort dso,sym\`, the"
echo "symbols grouped as this script says; share of all CPU samples of the process."
echo
for run in 640x480:raw 1920x1080:raw 640x480:jpeg90; do
  size="${run%%:*}" enc="${run#*:}"
  n=$([ "$size" = 640x480 ] && echo "$f640" || echo "$f1080")
  perf record -q -F 999 -o "$tmp/$run.data" -- "$build/tools/lf-gst-bench" --input "$data" \
    --sizes "$size" --encodings "$enc" --frames "$n" --skip-bound > "$tmp/$run.md" 2> "$tmp/err" || {
    echo "profile-bench: perf record of lf-gst-bench failed at $run:" >&2; cat "$tmp/err" >&2; exit 1; }
  perf report -i "$tmp/$run.data" --no-children --sort dso,sym --stdio -q -t '@' 2> /dev/null \
    > "$tmp/$run.txt"
done
python3 - "$tmp" <<'EOF'
import re, sys
tmp = sys.argv[1]
# First match wins: (category, dso pattern, symbol pattern).
rules = [
    ("warp kernels (lf/render/kernels.h, render_rows)", None,
     r"lf::kernels::|render_rows|row_extent|warp_rows|sample_"),
    ("adding and resolving (lf/render/composite.h)", None,
     r"accumulate_|resolve_|Compositor::|LayerCompositor|add_squares"),
    ("JPEG coding (libturbojpeg, the fragments' JPEG framing and decoding)", r"libturbojpeg",
     r"write_jpeg|parse_fragment_impl|decode_jpeg|serialize_jpeg|compress|extractChannel|"
     r"mixChannels"),
    ("planning (lf/render/plan.h, view geometry)", None,
     r"plan_|camera_parts|facet_|ViewGeometry|answer_request|FragmentPlan|plan\b|Plan"),
    ("copies and fills (memcpy, memset)", None, r"memmove|memcpy|memset|_M_fill_assign"),
    ("allocation and page faults", None,
     r"malloc|free|_int_|cfree|page_fault|mm_fault|g_slice|memalign|mmap|munmap|clear_page|"
     r"alloc_pages|rmqueue|zap_|release_pages|lru|anonymous_page|pte|memcg|mem_cgroup|folio|_page"),
    ("threads and hand-offs (locks, wake-ups, scheduler, TBB)", r"libtbb",
     r"futex|schedule|sched|finish_task_switch|spin_|pthread_|g_mutex|g_cond|yield|wake|"
     r"switch_|__lll|syscall|clock_gettime|hrtimer|tick|irq|rcu|select_task|enqueue|dequeue|"
     r"update_|native_|entry_|ttwu|tbb"),
    ("GStreamer and GLib", r"libgst(?!lightfield)|libglib|libgobject", None),
    ("start-up (libraries, reading and decoding the images)",
     r"ld-linux|libpng|libjpeg|libz\.|imgcodecs|libwebp|libtiff",
     r"png_|jpeg_|inflate|_dl_|_copy_to_iter|filemap_|copy_page_to_iter"),
]
sizes = ["640x480:raw", "1920x1080:raw", "640x480:jpeg90"]
shares = {s: {} for s in sizes}
tops = {}
for s in sizes:
    for line in open(f"{tmp}/{s}.txt"):
        parts = [p.strip() for p in line.split("@")]
        if len(parts) < 3 or not parts[0].endswith("%"):
            continue
        pct = float(parts[0].rstrip("%"))
        dso, sym = parts[1], re.sub(r"^\[[.k]\]\s*", "", parts[2])
        cat = "other"
        for name, dpat, spat in rules:
            if (dpat and re.search(dpat, dso)) or (spat and re.search(spat, sym)):
                cat = name
                break
        shares[s][cat] = shares[s].get(cat, 0) + pct
        if s == "640x480:raw":
            short = re.sub(r"\(anonymous namespace\)::", "", sym)
            short = re.split(r"[(<]", short)[0][:40]
            if short.startswith("0x"):
                short = dso + " " + short
            tops.setdefault(cat, {})
            tops[cat][short] = tops[cat].get(short, 0) + pct
cats = [r[0] for r in rules] + ["other"]
print("| where the CPU goes | 640x480 raw | 1920x1080 raw | 640x480 JPEG q90 | largest symbols at 640x480 raw |")
print("|---|---|---|---|---|")
for c in cats:
    t = sorted(tops.get(c, {}).items(), key=lambda kv: -kv[1])[:3]
    top = ", ".join(f"`{k}` {v:.1f}" for k, v in t)
    cols = " | ".join(f"{shares[s].get(c, 0):.1f} %" for s in sizes)
    print(f"| {c} | {cols} | {top} |")
EOF
echo
echo "The runs' own rows (throughput under perf, so a little below an unprofiled run's):"
echo
for run in 640x480:raw 1920x1080:raw 640x480:jpeg90; do
  grep "^| [0-9]*x[0-9]* | ${run#*:}" "$tmp/$run.md" || true
done
