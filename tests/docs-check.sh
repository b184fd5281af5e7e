#!/usr/bin/env bash
# The documentation runs as written (issue: a README a newcomer reads):
#  1. docs/elements.md is what tools/lf-elements prints from the built
#     plugin (a diff otherwise: regenerate it with the command the page
#     names), and README.md's element table names each element and klass;
#  2. every element's example pipeline (its "Example" metadata, shown by
#     gst-inspect-1.0 and on that page) runs to the end: exit status 0, no
#     ERROR or WARNING message;
#  3. every command block of README.md and docs/*.md marked runnable (a line
#     `<!-- runnable -->` right before the opening ```sh) runs from the
#     repository root, line by line (a line ending in a backslash goes on),
#     with exit status 0.
# Display sinks become fakesink (no display here); ../shared/data stands for
# the data folder this build was configured with. Each command has LIMIT
# seconds (default 300). Skipped (77) without the real data, which the
# commands read.
# usage: docs-check.sh BUILD_DIR SHARED_DATA
set -uo pipefail
build="$(cd "$1" && pwd)"; data="$2"
root="$(cd "$(dirname "$0")/.." && pwd)"
limit="${LIMIT:-300}"
export GST_PLUGIN_PATH="$build/gst"
fail=0 hangs=0
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT

# 1. The generated element reference.
if ! "$build/tools/lf-elements" -o "$work/elements.md"; then
  echo "FAIL: lf-elements did not run"; exit 1
fi
if diff -u "$root/docs/elements.md" "$work/elements.md" > "$work/elements.diff"; then
  echo "ok: docs/elements.md is what lf-elements prints"
else
  echo "FAIL: docs/elements.md differs from what lf-elements prints (regenerate:"
  echo "  GST_PLUGIN_PATH=build/gst build/tools/lf-elements -o docs/elements.md):"
  head -40 "$work/elements.diff"; fail=1
fi

# The README's element table names every element with its klass.
while IFS='|' read -r _ link klass _; do
  el="$(sed -n 's/.*`\([a-z]*\)`.*/\1/p' <<< "$link")"; klass="$(xargs <<< "$klass")"
  if ! grep -qF "| [\`$el\`](docs/elements.md#$el) | $klass |" "$root/README.md"; then
    echo "FAIL: README.md's element table lacks | [\`$el\`](docs/elements.md#$el) | $klass |"; fail=1
  fi
done < <(grep '^| \[`' "$work/elements.md")
[ "$fail" = 0 ] && echo "ok: README.md's element table names every element and its klass"

if [ ! -d "$data" ]; then
  echo "SKIP: the examples read the real data $data (absent; scripts/get-data.sh fetches it)"
  [ "$fail" = 0 ] && exit 77 || exit 1
fi
data="$(cd "$data" && pwd)"

# Runs one command from the repository root: 0 when it ended by itself with
# status 0 and (with $2 = quiet) no warning or error message.
run() {
  local cmd="$1" want_quiet="${2:-}" log="$work/run.log"
  cmd="${cmd//autovideosink/fakesink}"; cmd="${cmd//xvimagesink/fakesink}"
  cmd="${cmd//..\/shared\/data/$data}"
  local t0=$SECONDS rc
  # In a process group of its own: on a hang, every thread's backtrace of
  # each of its processes is printed (and kept in hang-N.txt) before the
  # group is killed, so a rare hang says where it waits.
  (cd "$root" && exec setsid bash -c "$cmd") > "$log" 2>&1 &
  local pid=$!
  while kill -0 "$pid" 2> /dev/null && ((SECONDS - t0 < limit)); do sleep 0.1; done
  if kill -0 "$pid" 2> /dev/null; then
    hangs=$((hangs + 1))
    echo "HUNG after $limit s: $1"
    "$root/tests/backtraces.sh" $(pgrep -g "$pid") > "$build/meson-logs/hang-$hangs.txt" 2>&1
    # A line a thread: its name and innermost eight functions.
    awk '/^== / { if (t) print t; t = ""; print; next }
         /^Thread / { if (t) print t; match($0, /"[^"]*"/); t = substr($0, RSTART, RLENGTH) ":"; n = 0; next }
         /^#/ && n < 8 { f = $0; sub(/^#[0-9]+ +(0x[0-9a-f]+ in )?/, "", f); sub(/ \(.*/, "", f)
                         if (f == "" && match($0, /[^\/]*$/)) f = "(" substr($0, RSTART) ")"
                         t = t " " f; n++ }
         END { if (t) print t }' "$build/meson-logs/hang-$hangs.txt" | sed 's/^/    /' | cut -c1-400
    echo "    (all of it: $build/meson-logs/hang-$hangs.txt)"
    kill -KILL -- "-$pid" 2> /dev/null
    wait "$pid" 2> /dev/null
    rc=124
  else
    wait "$pid"
    rc=$?
  fi
  if [ "$rc" != 0 ]; then
    echo "FAIL (exit $rc after $((SECONDS - t0)) s): $1"; tail -8 "$log" | sed 's/^/    /'; return 1
  fi
  if [ -n "$want_quiet" ] && grep -q '^\(ERROR\|WARNING\)' "$log"; then
    echo "FAIL (a warning or error): $1"; grep -m3 -A3 '^\(ERROR\|WARNING\)' "$log" | sed 's/^/    /'
    return 1
  fi
  echo "ok ($((SECONDS - t0)) s): ${1:0:110}"
}

# 2. The examples in the element metadata.
n=0
for el in $(sed -n 's/^| \[`\([a-z]*\)`\].*/\1/p' "$work/elements.md"); do
  ex="$(gst-inspect-1.0 "$el" | sed -n 's/^  Example *//p')"
  if [ -z "$ex" ]; then echo "FAIL: $el has no Example in its metadata"; fail=1; continue; fi
  run "$ex" quiet || fail=1
  n=$((n + 1))
done
[ "$n" -ge 9 ] || { echo "FAIL: only $n elements with examples (9 expected)"; fail=1; }

# 3. The command blocks marked runnable.
blocks=0
for md in "$root/README.md" "$root"/docs/*.md; do
  mapfile -t cmds < <(awk '
    /^<!-- runnable -->$/ { mark = 1; next }
    mark && /^```sh/ { inblock = 1; mark = 0; next }
    { mark = 0 }
    inblock && /^```/ { inblock = 0; if (cur != "") print cur; cur = ""; next }
    inblock {
      line = $0; sub(/[ \t]+#.*$/, "", line)
      if (line ~ /^[ \t]*(#|$)/ && cur == "") next
      if (line ~ /\\$/) { sub(/\\$/, "", line); cur = cur line; next }
      print cur line; cur = ""
    }' "$md")
  for c in "${cmds[@]}"; do
    [ -n "${c// }" ] || continue
    run "$c" || fail=1
    blocks=$((blocks + 1))
  done
done
echo "ran $n element examples and $blocks documented commands"
[ "$blocks" -ge 5 ] || { echo "FAIL: only $blocks runnable commands found in README.md and docs/"; fail=1; }
exit $fail
