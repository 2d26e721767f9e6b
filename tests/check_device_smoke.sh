#!/usr/bin/env bash
# tests/check_device_smoke.sh BUILD_DIR — tools/check_device.sh on device 0: every render
# succeeds (exit 0, one "ok" line each); with every device's kernel build failing
# (TESSERA_FAIL_BUILD='*') every render is reported, with the error, and the exit status is 1.
# Skipped (77) without an OpenCL device.
set -uo pipefail
build=$1
src=$(cd "$(dirname "$0")/.." && pwd)
log=$(mktemp)
trap 'rm -f "$log"' EXIT
bash "$src/tools/check_device.sh" --build "$build" --device 0 >"$log" 2>&1
rc=$?
cat "$log"
[ $rc -eq 77 ] && exit 77
[ $rc -eq 0 ] || { echo "check_device_smoke: exit status $rc on a working device"; exit 1; }
total=$(sed -n 's/^check_device: all \([0-9]*\) renders succeeded.*/\1/p' "$log")
[ -n "$total" ] || { echo "check_device_smoke: no summary line"; exit 1; }
[ "$(grep -c '^ok ' "$log")" -eq "$total" ] ||
  { echo "check_device_smoke: the ok lines do not count $total renders"; exit 1; }
TESSERA_FAIL_BUILD='*' bash "$src/tools/check_device.sh" --build "$build" --device 0 >"$log" 2>&1
rc=$?
cat "$log"
[ $rc -eq 1 ] || { echo "check_device_smoke: exit status $rc with every build failing (want 1)"; exit 1; }
fails=$(grep -c '^FAIL .*CL_BUILD_PROGRAM_FAILURE' "$log")
[ "$fails" -eq "$total" ] || { echo "check_device_smoke: $fails of $total renders reported failing"; exit 1; }
grep -q "^check_device: $total of $total renders failed on device 0" "$log" ||
  { echo "check_device_smoke: no summary line"; exit 1; }
echo "check_device_smoke: ok"
