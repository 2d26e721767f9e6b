#!/usr/bin/env bash
# tools/demo.sh — sets everything up (tools/setup.sh) and renders the default scene, the
# Utah teapot, to out/teapot.png, printing the per-stage timings.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
mkdir -p out
build/tessera devices
build/tessera render scene/teapot.rib -o out/teapot.png --stats out/teapot.json "$@"
echo "demo: wrote out/teapot.png (stats in out/teapot.json)"
