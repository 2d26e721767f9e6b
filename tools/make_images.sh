#!/usr/bin/env bash
# tools/make_images.sh — renders the README's two pictures into docs/images/: the displaced
# teapot and the 100-tree forest, small PNGs (tens of KB) so that the repository stays
# light. Run after tools/setup.sh; takes about a minute on 2 cores (forest-100 loads
# 111,927 patches). Environment: TESSERA (default build/tessera), SPP (default 16).
set -euo pipefail
cd "$(dirname "$0")/.."
tessera=${TESSERA:-build/tessera}
spp=${SPP:-16}
[ -x "$tessera" ] || { echo "make_images: $tessera not built (run tools/setup.sh)" >&2; exit 1; }
mkdir -p docs/images
# 480x270 for the teapot (16:9); 480x192 keeps the forest's 2.5:1 frame (its Format).
"$tessera" render scene/teapot_displaced.rib -o docs/images/teapot_displaced.png \
  --res 480x270 --spp "$spp" --quiet
"$tessera" render scene/forest-100.rib -o docs/images/forest.png --res 480x192 --spp "$spp" --quiet
ls -l docs/images/teapot_displaced.png docs/images/forest.png
