#!/usr/bin/env bash
# tools/rib_corpus.sh — how many RIB scenes of a collection Tessera loads, renders and lights
# (docs/rib.md "Public RIB files"). Every *.rib and *.rib.gz under DIR that holds
# "WorldBegin" is a scene; each is rendered small with BINARY (default build/tessera):
#   loads:  not refused with a scene error ("FILE:LINE:COL: error: ...") or as unreadable
#   renders: exit status 0
#   lit:    the image is not black (oiiotool --stats, from openimageio-tools)
# One line per scene goes to OUT/results.tsv (status, lit, first line of stderr, file), the
# counts to stdout.
# usage: tools/rib_corpus.sh DIR OUT [BINARY]
set -uo pipefail
dir=${1:?usage: tools/rib_corpus.sh DIR OUT [BINARY]}
out=${2:?usage: tools/rib_corpus.sh DIR OUT [BINARY]}
bin=${3:-build/tessera}
command -v oiiotool >/dev/null || { echo "rib_corpus: needs oiiotool (openimageio-tools)" >&2; exit 1; }
mkdir -p "$out"
: >"$out/results.tsv"
scenes=0 loaded=0 rendered=0 lit=0
while IFS= read -r -d '' f; do
  if [[ $f == *.gz ]]; then grep_src() { zcat -- "$f" 2>/dev/null; }; else grep_src() { cat -- "$f"; }; fi
  n=$(grep_src | grep -ac WorldBegin) # (grep -q would end the pipe early: SIGPIPE)
  [[ ${n:-0} -gt 0 ]] || continue
  scenes=$((scenes + 1))
  img="$out/$scenes.exr"
  timeout 600 "$bin" render "$f" -o "$img" --res 48x36 --spp 1 --max-lod 3 --memory 64 --quiet \
    2>"$out/stderr.txt"
  rc=$?
  first=$(grep -m1 'tessera:' "$out/stderr.txt" | tr '\t' ' ')
  # Not loaded: a scene error, or a file that could not be read (as RIB or as a mesh).
  [[ $rc -eq 0 || ($first != *": error: "* && $first != *"cannot read"*) ]] && loaded=$((loaded + 1))
  bright=0
  if [[ $rc -eq 0 ]]; then
    rendered=$((rendered + 1))
    bright=$(oiiotool --stats "$img" 2>/dev/null | awk '/Max:/ {m = 0; for (i = 3; i <= 5; i++) if ($i + 0 > m) m = $i + 0; print (m > 0) ? 1 : 0; exit}')
    lit=$((lit + ${bright:-0}))
  fi
  printf '%s\t%s\t%s\t%s\n' "$rc" "${bright:-0}" "$first" "$f" >>"$out/results.tsv"
done < <(find "$dir" \( -iname '*.rib' -o -iname '*.rib.gz' \) -type f -print0 | sort -z)
echo "scenes $scenes loaded $loaded rendered $rendered lit $lit"
