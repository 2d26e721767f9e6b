#!/usr/bin/env bash
# tools/gallery.sh — renders every scene in scene/ small and writes docs/gallery.md: one
# image a scene (docs/images/gallery/NAME.png), what the scene shows (its header comment)
# and the command that renders it at full size. Run after tools/setup.sh; a few minutes on
# 2 cores. Environment: TESSERA (default build/tessera), WIDTH (default 240; the height
# keeps the scene's Format aspect, 240x135 without one), SPP (default 4).
# A scene that only other scenes read (no WorldBegin of its own, e.g. teapots_world.rib)
# is listed with the scene that reads it. Exit status 1 when a render fails.
set -euo pipefail
cd "$(dirname "$0")/.."
tessera=${TESSERA:-build/tessera}
width=${WIDTH:-240}
spp=${SPP:-4}
[ -x "$tessera" ] || { echo "gallery: $tessera not built (run tools/setup.sh)" >&2; exit 1; }
out=docs/images/gallery
mkdir -p "$out"
md=docs/gallery.md.tmp
{
  echo "# Gallery"
  echo
  echo "Every scene in scene/, rendered small by \`tools/gallery.sh\` (${width} pixels wide, $spp"
  echo "samples a pixel, the scene's own camera and lights). Each command renders the scene at"
  echo "its own resolution and samples; add \`--res WxH --spp N\` for a quick look. What the RIB"
  echo "requests mean is in [rib.md](rib.md)."
  echo
} > "$md"

# The header comment's first sentence: "# NAME.rib -- what it is ...".
describe() {
  awk 'NR > 1 && !/^#/ { exit } /^##/ { next } /^#/ { sub(/^# ?/, ""); printf "%s ", $0 }' "$1" |
    sed -e 's/^[^ ]* -- //' -e 's/\([.:]\) .*/\1/' -e 's/[.:] *$//' -e 's/ *$//'
}

failed=0
for rib in scene/*.rib; do
  name=$(basename "$rib" .rib)
  if ! grep -qE '^[[:space:]]*WorldBegin' "$rib" &&
    grep -lE "ReadArchive \"$name\.rib\"" scene/*.rib >/dev/null; then
    echo "gallery: $rib is a world that other scenes read (no WorldBegin), skipped"
    continue
  fi
  read -r fw fh < <(awk '/^Format/ { print $2, $3; exit }' "$rib") || true
  if [ -n "${fw:-}" ] && [ "${fw:-0}" -gt 0 ]; then
    height=$(( (width * fh + fw / 2) / fw ))
  else
    height=$(( width * 9 / 16 ))
  fi
  res="${width}x${height}"
  start=$(date +%s.%N)
  if ! "$tessera" render "$rib" -o "$out/$name.png" --res "$res" --spp "$spp" --quiet; then
    echo "gallery: $rib failed" >&2
    failed=1
    continue
  fi
  secs=$(echo "$(date +%s.%N) - $start" | bc)
  printf 'gallery: %-40s %s %5.1f s\n' "$rib" "$res" "$secs"
  {
    echo "## $name"
    echo
    echo "$(describe "$rib")."
    echo
    echo "![$name](images/gallery/$name.png)"
    echo
    # tests/docs/doc_commands.py runs the sh blocks of docs/; a scene that takes more than a
    # few seconds even this small is marked to be left out there.
    if [ "$(echo "$secs > 5" | bc)" = 1 ]; then
      echo "<!-- doc-test: skip (this scene takes minutes at its own size) -->"
    fi
    echo '```sh'
    echo "build/tessera render $rib -o out/$name.png"
    echo '```'
    echo
  } >> "$md"
  unset fw fh
done
mv "$md" docs/gallery.md
du -ch "$out"/*.png | tail -1
exit $failed
