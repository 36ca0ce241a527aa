#!/bin/bash
# Triangle quality table of docs/quality.md: for every corpus surface, at the
# default options and at --level 8, the triangle count, aspect_good and the
# smoothing time of two isoc binaries (before and after), as a Markdown table.
# usage: docs/quality.sh BEFORE_BINARY AFTER_BINARY   (run from the repo root)
set -e
row() { # binary file extra-args -> "triangles aspect smooth_ms watertight euler genus"
  "$1" mesh "$2" $3 --stats json -o /tmp/isoc_quality_$$.obj 2>/dev/null | head -1 |
    jq -r '[.triangles, .aspect_good, .timings_ms.smooth, .watertight, .euler, (.genus|tostring)] | @tsv'
}
echo "| surface | options | triangles | aspect_good before | after | smooth ms before | after | topology kept |"
echo "|---|---|---|---|---|---|---|---|"
for f in corpus/*.iso; do
  for opt in "" "--level 8"; do
    read -r tb ab sb wb eb gb <<<"$(row "$1" "$f" "$opt")"
    read -r ta aa sa wa ea ga <<<"$(row "$2" "$f" "$opt")"
    same=$([ "$tb $wb $eb $gb" = "$ta $wa $ea $ga" ] && echo yes || echo NO)
    printf "| %s | %s | %d | %.3f | %.3f | %.1f | %.1f | %s |\n" \
      "$(basename "$f" .iso)" "${opt:-default}" "$ta" "$ab" "$aa" "$sb" "$sa" "$same"
  done
done
rm -f /tmp/isoc_quality_$$.obj
