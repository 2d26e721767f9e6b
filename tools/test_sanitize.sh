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
# A kernel compiled inside an instrumented process makes PoCL dlopen the freshly built kernel
# library, whose dynamic TLS LeakSanitizer's tracer cannot walk: it crashes at exit ("Tracer
# caught signal 11", "LeakSanitizer has encountered a fatal error") in whichever test compiles
# first. So build, compile the kernels once into the cache with leak checking off, and let
# every test load them from there (loading a cached binary does not upset the tracer).
tools/setup.sh
# Mesa's OpenCL ICDs (mesa-opencl-icd: Rusticl for tests/check_rusticl.sh in the plain suite,
# and Clover) are loaded into every process by the ICD loader and leak at load, outside any
# frame LeakSanitizer can name. This suite checks Tessera's code on PoCL alone: the loader
# sees only PoCL's .icd (check_rusticl then skips here; it runs in tools/test.sh).
vendors="$PWD/$BUILD_DIR/ocl-vendors"
rm -rf "$vendors" && mkdir -p "$vendors"
for icd in /etc/OpenCL/vendors/pocl*.icd; do
  [ -e "$icd" ] && cp "$icd" "$vendors/"
done
export OCL_ICD_VENDORS="$vendors"
ASAN_OPTIONS=detect_leaks=0 "$BUILD_DIR/tessera" render scene/one_patch.rib -o "$BUILD_DIR/warm.exr" \
  --res 8x8 --spp 1 --max-lod 1 --quiet
exec tools/test.sh "$@"
