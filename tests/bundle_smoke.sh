#!/usr/bin/env bash
# tests/bundle_smoke.sh BUILD_DIR — tools/bundle.sh: packs the build (fast compression),
# unpacks it into another directory and runs `tessera --help` and a host-only test there
# through bundle/run.sh, with the bundle's libraries and the suite's paths made the new ones.
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$1" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
BUNDLE_XZ=-0 "$src/tools/bundle.sh" make "$build" "$tmp/b.tar.xz" >/dev/null
mkdir "$tmp/checkout"
tar xJf "$tmp/b.tar.xz" -C "$tmp/checkout"
b=$tmp/checkout/bundle
missing=$(LD_LIBRARY_PATH=$b/lib ldd "$b/build/tessera" "$b/build/tests/test_units" | grep "not found" || true)
[ -z "$missing" ] || { echo "bundle: libraries missing: $missing" >&2; exit 1; }
"$b/run.sh" tessera --help | grep -q "usage: tessera devices" || { echo "bundle: tessera --help failed" >&2; exit 1; }
"$b/run.sh" ctest -R '^test_units$' >"$tmp/ctest.txt" 2>&1 || { cat "$tmp/ctest.txt" >&2; exit 1; }
grep -q "100% tests passed, 0 tests failed out of 1" "$tmp/ctest.txt" || { cat "$tmp/ctest.txt" >&2; exit 1; }
if grep -q "$build/" "$b/build/tests/CTestTestfile.cmake"; then
  echo "bundle: the suite still names $build" >&2
  exit 1
fi
echo "bundle_smoke: ok"
