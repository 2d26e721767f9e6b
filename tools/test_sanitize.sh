#!/usr/bin/env bash
# tools/test_sanitize.sh — the whole test suite on a build with AddressSanitizer and
# UndefinedBehaviorSanitizer (-DTESSERA_SANITIZE=ON) in build-asan/. Any ASan report (heap
# or stack overflow, use after free, double free), any UBSan report (which aborts:
# -fno-sanitize-recover) and any leak outside the OpenCL driver stack (tools/lsan.supp)
# fails the test it happens in. Extra arguments go to ctest, as for tools/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
export BUILD_DIR=${BUILD_DIR:-build-asan}
export CMAKE_ARGS=${CMAKE_ARGS:--DTESSERA_SANITIZE=ON}
export TESSERA_CACHE_DIR=${TESSERA_CACHE_DIR:-$PWD/$BUILD_DIR/kernel-cache}
# PoCL and LLVM are not instrumented; their allocations held until exit are not Tessera's.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:strict_string_checks=1:check_initialization_order=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tools/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
exec tools/test.sh "$@"
