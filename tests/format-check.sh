#!/usr/bin/env bash
# The C and C++ sources are formatted as .clang-format says
# (`clang-format --dry-run -Werror`); fix with `clang-format -i FILE`.
# usage: format-check.sh   (from anywhere; reads the repository's git index)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
command -v clang-format > /dev/null || { echo "FAIL: clang-format is not installed (scripts/test.sh installs it)"; exit 1; }
mapfile -t files < <(git ls-files '*.cpp' '*.h' '*.c' 2>/dev/null || find lib gst calib tools tests docs/examples -name '*.cpp' -o -name '*.h' -o -name '*.c')
[ "${#files[@]}" -gt 50 ] || { echo "FAIL: only ${#files[@]} sources found"; exit 1; }
if clang-format --dry-run -Werror "${files[@]}" 2> "${TMPDIR:-/tmp}/format-check.$$"; then
  echo "ok: ${#files[@]} files formatted as .clang-format says"; rm -f "${TMPDIR:-/tmp}/format-check.$$"
else
  grep -m20 'error:' "${TMPDIR:-/tmp}/format-check.$$"; rm -f "${TMPDIR:-/tmp}/format-check.$$"
  echo "FAIL: files differ from .clang-format (clang-format -i FILE)"; exit 1
fi
