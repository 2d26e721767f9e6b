#!/usr/bin/env bash
# tools/bundle.sh — packs a build for a machine that has an OpenCL driver but not Tessera's
# build dependencies (a GPU box without Debian's -dev packages or network), and runs it there.
#
#   tools/bundle.sh make [BUILD_DIR] [OUT.tar.xz]   # here: the build's programs and tests, the
#                                                  # shared libraries they need (glibc's and the
#                                                  # OpenCL drivers' left out), the shared data
#   tar xJf tessera-bundle.tar.xz -C DIR           # there, in a checkout of the same commit
#   DIR/bundle/run.sh tessera devices              # any command, with the bundle's libraries
#   DIR/bundle/run.sh ctest -j 8                   # the suite, its paths made the checkout's
#
# run.sh uses the machine's libstdc++ and libgcc_s instead of the bundle's when they are as new
# (an OpenCL driver loaded into the process may need the newer), and exports TESSERA_CACHE_DIR (default bundle/kernel-cache). The OpenCL ICD
# loader comes along (libOpenCL.so.1); the drivers are the machine's (/etc/OpenCL/vendors, or
# OCL_ICD_VENDORS=DIR of .icd files naming them, e.g. NVIDIA's libnvidia-opencl.so.1).
# The OpenImageIO module (libtessera_image.so, ~260 libraries) is left out: EXR and PNG output
# and EXR textures work, other texture formats do not (docs/errors.md).
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
make) ;;
*) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 2 ;;
esac
build=$(cd "${2:-build}" && pwd)
out=${3:-tessera-bundle.tar.xz}
[ -x "$build/tessera" ] || { echo "bundle: $build/tessera is not built (tools/setup.sh)" >&2; exit 1; }
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
b=$stage/bundle
mkdir -p "$b/build/tests" "$b/lib" "$b/shared"
programs=("$build/tessera")
for f in "$build"/bench_* "$build"/tests/test_*; do [ -x "$f" ] && [ -f "$f" ] && programs+=("$f"); done
for f in "${programs[@]}"; do
  rel=${f#"$build"/}
  cp "$f" "$b/build/$rel"
  strip "$b/build/$rel" 2>/dev/null || true
done
cp "$build/CTestTestfile.cmake" "$b/build/"
[ -f "$build/tests/CTestTestfile.cmake" ] && cp "$build/tests/CTestTestfile.cmake" "$b/build/tests/"
# The shared libraries the programs need, but glibc's own (the machine's must be used).
ldd "${programs[@]}" 2>/dev/null | awk '/=> \//{print $3}' | sort -u | while read -r lib; do
  case $(basename "$lib") in
  libc.so.* | libm.so.* | libpthread.so.* | libdl.so.* | librt.so.* | ld-linux*) ;;
  *) cp -L "$lib" "$b/lib/" ;;
  esac
done
# The paths the build recorded (its source tree, and the shared data beside it, as
# tests/CMakeLists.txt names it), for run.sh to replace with the machine's.
source=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
shared=$source/../shared
[ -d "$shared/data" ] && cp -rL "$shared/data" "$b/shared/"
printf 'build=%s\nsource=%s\nshared=%s\n' "$build" "$source" "$shared" >"$b/paths"
cat >"$b/run.sh" <<'RUN'
#!/usr/bin/env bash
# bundle/run.sh COMMAND... — runs COMMAND with this bundle's programs and libraries
# (made by tools/bundle.sh; `tessera` and `ctest` run from the bundle's build directory).
set -eu
b=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$b/.." && pwd)
. "$b/paths"
# The C++ runtime: the machine's when it is at least as new as the bundle's (a driver loaded
# into the process, NVIDIA's or a newer PoCL, may need the newer one).
newest() { grep -ao "$1[0-9.]*" "$2" 2>/dev/null | sort -V | tail -1; }
for pair in libstdc++.so.6:GLIBCXX_3.4. libgcc_s.so.1:GCC_; do
  name=${pair%%:*} tag=${pair#*:}
  [ -f "$b/lib/$name" ] || continue
  sys=$(ldconfig -p 2>/dev/null | awk -v n="$name" '$1 == n && /x86-64/ {p = $NF} END {print p}')
  [ -n "$sys" ] || continue
  mine=$(newest "$tag" "$b/lib/$name") theirs=$(newest "$tag" "$sys")
  [ "$(printf '%s\n%s\n' "$mine" "$theirs" | sort -V | tail -1)" = "$theirs" ] && rm -f "$b/lib/$name"
done
if [ ! -f "$b/build/.paths-done" ]; then
  for f in "$b/build/CTestTestfile.cmake" "$b/build/tests/CTestTestfile.cmake"; do
    [ -f "$f" ] && sed -i "s#$build#$b/build#g; s#$shared#$b/shared#g; s#$source#$src#g" "$f"
  done
  touch "$b/build/.paths-done"
fi
export LD_LIBRARY_PATH=$b/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export TESSERA_CACHE_DIR=${TESSERA_CACHE_DIR:-$b/kernel-cache}
export TESSERA_BINARY=$b/build/tessera TESSERA_SOURCE_DIR=$src TESSERA_SHARED_DIR=$b/shared
case "$1" in
tessera) shift; exec "$b/build/tessera" "$@" ;;
ctest) shift; exec ctest --test-dir "$b/build" --output-on-failure "$@" ;;
*) exec "$@" ;;
esac
RUN
chmod +x "$b/run.sh"
tar -C "$stage" -cf - bundle | xz -T0 "${BUNDLE_XZ:--6}" >"$out"
echo "bundle: $out ($(du -h "$out" | cut -f1)); there: tar xJf $(basename "$out") -C CHECKOUT && CHECKOUT/bundle/run.sh tessera devices"
