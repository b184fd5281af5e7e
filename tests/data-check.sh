#!/usr/bin/env bash
# scripts/get-data.sh --verify: the real data in place matches the committed
# SHA-256 sums, and a copy with one changed byte or one missing file fails by
# name. Skipped (77) without the real data.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"; data="$1"
if [ ! -d "$data" ]; then
  echo "SKIP: needs the real data $data (absent; scripts/get-data.sh fetches it)"; exit 77
fi
"$root/scripts/get-data.sh" --verify "$data"
t="$(mktemp -d)"; trap 'rm -rf "$t"' EXIT
mkdir "$t/middlebury-temple"
for f in "$data"/middlebury-temple/*; do ln -s "$f" "$t/middlebury-temple/"; done
rm "$t/middlebury-temple/templeSR_par.txt"
sed 's/^16$/17/' "$data/middlebury-temple/templeSR_par.txt" > "$t/middlebury-temple/templeSR_par.txt"
cmp -s "$t/middlebury-temple/templeSR_par.txt" "$data/middlebury-temple/templeSR_par.txt" && { echo "FAIL: the test file was not changed"; exit 1; }
rm "$t/middlebury-temple/templeSR0001.png"
if out=$("$root/scripts/get-data.sh" --verify --only middlebury-temple "$t" 2>&1); then
  echo "FAIL: a changed and a missing file were accepted"; exit 1
fi
grep -q "mismatch: .*templeSR_par.txt" <<<"$out" || { echo "FAIL: the changed file is not named: $out"; exit 1; }
grep -q "missing .*templeSR0001.png" <<<"$out" || { echo "FAIL: the missing file is not named: $out"; exit 1; }
echo "data-check: sums hold; a changed and a missing file are named"
