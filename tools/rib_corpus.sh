#!/usr/bin/env bash
# tools/rib_corpus.sh — how many RIB scenes of a collection Tessera loads, renders and lights
# (docs/rib.md "Public RIB files"). Every *.rib and *.rib.gz under DIR that holds
# "WorldBegin" is a scene; each is rendered small with BINARY (default build/tessera):
#   loads:  not refused with a scene error ("FILE:LINE:COL: error: ...") or as unreadable
#   renders: exit status 0
#   lit:    the image (PNG) is not black
#   by its own lights: lit, and not by the headlight Tessera adds to a scene without lights
# One line per scene goes to OUT/results.tsv (status, lit, own lights, first line of stderr,
# file), the counts to stdout.
# usage: tools/rib_corpus.sh [--programs] DIR OUT [BINARY]
#        tools/rib_corpus.sh [--programs] --list FILE DIR OUT [BINARY]
# The scenes are other people's files: their Procedural "RunProgram" helpers are not run
# (--no-programs: a warning, and the scene without them) unless --programs is given.
# --list: the scenes FILE names, one a line relative to DIR (binary RIB, whose requests grep
# cannot see, and top-level files among archives), each optionally followed by a TAB and the
# directory, relative to DIR, to render it from (RenderMan for Maya's paths are relative to
# its project); lines starting with # are skipped.
set -uo pipefail
list=""
programs=--no-programs
if [[ ${1:-} == --programs ]]; then programs=""; shift; fi
if [[ ${1:-} == --list ]]; then list=${2:?usage: tools/rib_corpus.sh --list FILE DIR OUT [BINARY]}; shift 2; fi
dir=${1:?usage: tools/rib_corpus.sh DIR OUT [BINARY]}
out=${2:?usage: tools/rib_corpus.sh DIR OUT [BINARY]}
bin=$(realpath "${3:-build/tessera}")
mkdir -p "$out"
out=$(realpath "$out")
dir=$(realpath "$dir")
# bright IMG: 1 when any pixel of the PNG is not black (Python's zlib reads it: no extra tool)
bright() {
  python3 - "$1" <<'PY'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
pos, idat, w, h = 8, b"", 0, 0
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    if kind == b"IHDR": w, h = struct.unpack(">II", data[pos + 8:pos + 16])
    if kind == b"IDAT": idat += data[pos + 8:pos + 8 + n]
    pos += 12 + n
raw = zlib.decompress(idat)
print(1 if any(b for i, b in enumerate(raw) if i % (w * 3 + 1)) else 0)
PY
}
: >"$out/results.tsv"
scenes=0 loaded=0 rendered=0 lit=0 own=0
scene_list() {
  if [[ -n $list ]]; then
    grep -v '^#' "$list" | while IFS=$'\t' read -r f from; do
      [[ -n $f ]] && printf '%s\t%s\0' "$dir/$f" "$dir/${from:-$(dirname "$f")}"
    done
  else
    find "$dir" \( -iname '*.rib' -o -iname '*.rib.gz' \) -type f -print0 | sort -z |
      while IFS= read -r -d '' f; do
        if [[ $f == *.gz ]]; then n=$(zcat -- "$f" 2>/dev/null | grep -ac WorldBegin); else n=$(grep -ac WorldBegin -- "$f"); fi
        [[ ${n:-0} -gt 0 ]] && printf '%s\t%s\0' "$f" "$(dirname "$f")"
      done
  fi
}
while IFS=$'\t' read -r -d '' f from; do
  scenes=$((scenes + 1))
  img="$out/$scenes.png"
  (cd "$from" && timeout 600 "$bin" render "$f" -o "$img" --res 48x36 --spp 1 --max-lod 3 \
    --memory 64 $programs 2>"$out/stderr.txt" >/dev/null)
  rc=$?
  first=$(grep -m1 ': error: ' "$out/stderr.txt" | tr '\t' ' ')
  [[ -n $first ]] || first=$(grep -m1 'warning: ' "$out/stderr.txt" | tr '\t' ' ')
  # Not loaded: a scene error, or a file that could not be read (as RIB or as a mesh).
  [[ $rc -eq 0 || ($first != *": error: "* && $first != *"cannot read"*) ]] && loaded=$((loaded + 1))
  b=0 mine=0
  if [[ $rc -eq 0 ]]; then
    rendered=$((rendered + 1))
    b=$(bright "$img")
    lit=$((lit + ${b:-0}))
    [[ ${b:-0} == 1 ]] && ! grep -q 'has no light Tessera renders' "$out/stderr.txt" && mine=1
    own=$((own + mine))
  fi
  printf '%s\t%s\t%s\t%s\t%s\n' "$rc" "${b:-0}" "$mine" "$first" "$f" >>"$out/results.tsv"
done < <(scene_list)
echo "scenes $scenes loaded $loaded rendered $rendered lit $lit by-own-lights $own"
