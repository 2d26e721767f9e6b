#!/usr/bin/env bash
# tools/test.sh — sets everything up (tools/setup.sh), then runs the whole test suite with
# ctest. Extra arguments go to ctest (e.g. -R trace, -V).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
# A private kernel cache per run, so a stale binary can never hide a kernel change.
export TESSERA_CACHE_DIR=${TESSERA_CACHE_DIR:-$PWD/build/kernel-cache}
ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j "$(nproc)" --timeout 600 "$@"
