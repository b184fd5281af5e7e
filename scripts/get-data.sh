#!/usr/bin/env bash
# Fetches the public datasets that the demo and the real-data tests read
# (../shared/data in this team's checkout) from their original publishers and
# checks every file against the SHA-256 sums in scripts/data.sha256, which were
# taken from ../shared/data (its SHA256SUMS files, and the files themselves for
# the two folders without one). Nothing is kept that does not match.
#
# usage: scripts/get-data.sh [--verify] [--only DATASET] [DIR]
#   DIR            where the dataset folders go (default: ../shared/data)
#   --verify       check DIR against the sums only; no network
#   --only NAME    one dataset (e.g. stanford-chess); default: all of them
#   --make-manifest SRC   (maintainers) write scripts/data.sha256 from SRC
# Exit status: 0 when every requested file is present and matches; 1 otherwise
# (each missing or mismatching file is named).
#
# Sources (the publishers; licences and citations: README "Data and credits"):
#   stanford-chess     The (New) Stanford Light Field Archive, "Chess" rectified
#   hci-cotton         HCI 4D Light Field Benchmark (registration: manual)
#   blender-shop-9x9   github.com/linusmossberg/light-field-renderer (MIT), pinned commit
#   middlebury-*       Middlebury multi-view stereo, sparse rings
#   caltech-calib      Bouguet's Camera Calibration Toolbox, first example
#   opencv-chessboard  Debian's opencv-doc 4.6.0 package (OpenCV samples/data)
#   bal-ladybug-49     Bundle Adjustment in the Large, Ladybug problem 49
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
manifest="$root/scripts/data.sha256"
dir="$root/../shared/data"; verify_only=0; only=""
while [ $# -gt 0 ]; do
  case "$1" in
    --verify) verify_only=1 ;;
    --only) only="$2"; shift ;;
    --make-manifest)
      src="$2"
      (cd "$src" && for d in */; do
        d="${d%/}"
        # The publisher's files: those named in the folder's provenance list or
        # SHA256SUMS (not the notes written when the folder was assembled).
        names=$({ cat "$d"/PROVENANCE_git_blobs.txt "$d"/SHA256SUMS 2>/dev/null || true; } |
          sed -E 's/^[0-9a-f]{40,64}  (\.\/)?//; s|.*/||' | sort -u)
        while IFS= read -r n; do
          if [ -f "$d/$n" ]; then sha256sum "$d/$n"; fi
        done <<<"$names"
        if [ -f "$d/SHA256SUMS" ]; then (cd "$d" && sha256sum -c --quiet SHA256SUMS) >&2; fi
      done) > "$manifest"
      echo "get-data: wrote $(wc -l < "$manifest") sums to $manifest"; exit 0 ;;
    -h|--help) sed -n '2,/^set -e/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) echo "get-data: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) dir="$1" ;;
  esac
  shift
done
datasets=$(cut -d' ' -f3- "$manifest" | cut -d/ -f1 | sort -u)
if [ -n "$only" ]; then
  grep -qx "$only" <<<"$datasets" || { echo "get-data: no dataset '$only' (one of: $(echo $datasets))" >&2; exit 2; }
  datasets="$only"
fi

verify() {  # verify DATASET: 0 when every file of it in DIR matches its sum
  local d="$1" bad=0
  while read -r sum name; do
    if [ ! -f "$dir/$name" ]; then echo "get-data: missing $dir/$name" >&2; bad=1
    elif [ "$(sha256sum < "$dir/$name" | cut -d' ' -f1)" != "$sum" ]; then
      echo "get-data: SHA-256 mismatch: $dir/$name" >&2; bad=1
    fi
  done < <(grep "  $d/" "$manifest")
  return $bad
}

fetch() {  # fetch DATASET TMP: downloads into TMP (any layout)
  local d="$1" t="$2"
  local get=(curl -fL --retry 2 --connect-timeout 20 -o)
  case "$d" in
    stanford-chess)
      "${get[@]}" "$t/a.zip" http://lightfield.stanford.edu/data/chess_lf/rectified.zip && unzip -q "$t/a.zip" -d "$t" ;;
    blender-shop-9x9)
      local base=https://raw.githubusercontent.com/linusmossberg/light-field-renderer/78299d03cafe283d29e3adb4943115db3e02b2ab/light-fields/shop
      while read -r _ name; do
        local f="${name#*/}"
        "${get[@]}" "$t/$f" "$base/${f// /%20}" || return 1
      done < <(grep "  $d/" "$manifest") ;;
    middlebury-temple | middlebury-dino)
      local s; s="${d#middlebury-}SparseRing"
      "${get[@]}" "$t/a.zip" "https://vision.middlebury.edu/mview/data/data/$s.zip" && unzip -q "$t/a.zip" -d "$t" ;;
    caltech-calib)
      "${get[@]}" "$t/a.zip" http://www.vision.caltech.edu/bouguetj/calib_doc/htmls/calib_example/calib_example.zip &&
        unzip -q "$t/a.zip" -d "$t" ;;
    opencv-chessboard)
      (cd "$t" && apt-get download opencv-doc=4.6.0+dfsg-12) && dpkg-deb -x "$t"/opencv-doc_*.deb "$t/x" &&
        cp "$t/x/usr/share/doc/opencv-doc/copyright" "$t/debian_copyright.txt" ;;
    bal-ladybug-49)
      "${get[@]}" "$t/p.bz2" https://grail.cs.washington.edu/projects/bal/data/ladybug/problem-49-7776-pre.txt.bz2 &&
        bunzip2 -c "$t/p.bz2" > "$t/problem-49-7776-pre.txt" ;;
    hci-cotton)
      echo "get-data: hci-cotton is handed out after registration at https://lightfield-analysis.uni-konstanz.de/ ;" \
        "put the scene's files in $dir/hci-cotton/ and run: scripts/get-data.sh --verify --only hci-cotton" >&2
      return 1 ;;
  esac
}

status=0
for d in $datasets; do
  if verify "$d" 2>/dev/null; then echo "get-data: $d ok ($(grep -c "  $d/" "$manifest") files)"; continue; fi
  if [ "$verify_only" = 1 ]; then verify "$d" || true; status=1; continue; fi
  echo "get-data: fetching $d ..."
  t="$(mktemp -d)"
  if fetch "$d" "$t"; then
    mkdir -p "$dir/$d"
    # Keep exactly the files named in the sums, wherever the archive put them.
    while read -r sum name; do
      f="$(find "$t" -type f -name "${name##*/}" -print -quit)"
      if [ -n "$f" ] && [ "$(sha256sum < "$f" | cut -d' ' -f1)" = "$sum" ]; then cp "$f" "$dir/$name"; fi
    done < <(grep "  $d/" "$manifest")
  fi
  rm -rf "$t"
  if verify "$d"; then echo "get-data: $d ok"; else echo "get-data: $d incomplete (above)" >&2; status=1; fi
done
exit $status
