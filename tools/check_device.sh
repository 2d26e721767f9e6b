#!/usr/bin/env bash
# tools/check_device.sh — does Tessera render on this OpenCL device? A dozen small renders that
# between them reach every stage and kernel path (eye rays alone, paths with bounces and shadow
# rays, leaf boxes and micro-triangles, the work-group leaf kernel, displacement, textures,
# point and spot lights, moving patches, instances, a budget that evicts patches), each on the
# device given. A render that fails is rendered again with TESSERA_SYNC_LAUNCHES=1, which waits
# after every kernel launch, so that the stage whose kernel failed is named (a GPU reports a
# faulting kernel only at the next wait: docs/errors.md). Run it first on a new device or
# driver; with tools/bundle.sh, through bundle/run.sh on a machine without the build
# dependencies (docs/building.md).
#
# Usage: tools/check_device.sh [--device I] [--build DIR] [--out DIR]
#   --device I  the device of `tessera devices` to check (default 0)
#   --build DIR the build to run (default $BUILD_DIR, else build; or $TESSERA_BINARY)
#   --out DIR   keep the images and each render's stderr there (default: a temporary
#               directory, removed at the end)
# Prints one line a render, "ok" or "FAIL" with the error and the stage named with
# TESSERA_SYNC_LAUNCHES=1 ("skip" for textured.rib where the OpenImageIO module that reads its
# PPM textures is absent, as in a bundle). Exit status: 0 every render succeeded (or was
# skipped), 1 one or more failed, 2 bad usage, 77 no OpenCL device (or the device index does
# not exist).
# The images are not compared with another device's: devices differ in the last bits of their
# transcendental functions (docs/benchmarks.md, "CPU + GPU"); this checks that every path runs.
set -uo pipefail
cd "$(dirname "$0")/.."
device=0 build=${BUILD_DIR:-build} out=""
while [ $# -gt 0 ]; do
  case $1 in
  --device) device=${2:?--device takes an index}; shift 2 ;;
  --build) build=${2:?--build takes a directory}; shift 2 ;;
  --out) out=${2:?--out takes a directory}; shift 2 ;;
  -h | --help) sed -n '2,23p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "check_device: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done
bin=${TESSERA_BINARY:-$build/tessera}
[ -x "$bin" ] || { echo "check_device: $bin is not built (tools/setup.sh)" >&2; exit 2; }
if ! "$bin" devices >/dev/null 2>&1; then
  echo "check_device: no OpenCL device ('tessera devices' fails): skipping"
  exit 77
fi
name=$("$bin" devices 2>/dev/null | sed -n "s/^$device: //p")
if [ -z "$name" ]; then
  echo "check_device: there is no device $device ('tessera devices' lists them): skipping"
  exit 77
fi
echo "check_device: device $device: $name"
if [ -n "$out" ]; then
  mkdir -p "$out" || exit 2
  work=$out
else
  work=$(mktemp -d "${TMPDIR:-/tmp}/check-device-XXXXXX")
  trap 'rm -rf "$work"' EXIT
fi
# name|arguments: small sizes, so that the whole check takes seconds on a CPU.
renders=(
  "eye_rays|scene/one_patch.rib --res 32x32 --spp 1 --depth 0"
  "paths|scene/one_patch.rib --res 32x32 --spp 2 --depth 3"
  "teapot|scene/teapot.rib --res 64x36 --spp 2"
  "displaced|scene/teapot_displaced.rib --res 64x36 --spp 2"
  "triangles|scene/teapot_displaced.rib --res 64x36 --spp 2 --intersect triangles"
  "group_leaves|scene/teapot.rib --res 64x36 --spp 1 --leaf-mode group --leaf-size 2"
  "textured|scene/textured.rib --res 64x36 --spp 2"
  "lights|scene/lights.rib --res 64x36 --spp 2 --sampling light"
  "motion|scene/motion.rib --res 64x36 --spp 2"
  "instances|scene/instances_displaced.rib --res 64x36 --spp 1"
  "small_budget|scene/teapot_displaced.rib --res 64x36 --spp 2 --memory 32"
)
failed=0 skipped=0
for r in "${renders[@]}"; do
  n=${r%%|*}
  read -r -a args <<<"${r#*|}"
  t0=$(date +%s%N)
  if "$bin" render "${args[@]}" --device "$device" --quiet -o "$work/$n.exr" 2>"$work/$n.stderr"; then
    ms=$((($(date +%s%N) - t0) / 1000000))
    printf 'ok    %-13s (%d.%02d s)\n' "$n" $((ms / 1000)) $((ms % 1000 / 10))
    continue
  fi
  # Not the device's failure: a bundle (tools/bundle.sh) leaves out the OpenImageIO module
  # that reads textured.rib's PPM textures.
  if grep -q 'cannot load the image module' "$work/$n.stderr"; then
    skipped=$((skipped + 1))
    printf 'skip  %-13s (the image module is not there to read its textures)\n' "$n"
    continue
  fi
  failed=$((failed + 1))
  printf 'FAIL  %-13s %s\n' "$n" "$(grep -v '^ ' "$work/$n.stderr" | tail -1)"
  TESSERA_SYNC_LAUNCHES=1 "$bin" render "${args[@]}" --device "$device" --quiet \
    -o "$work/$n.sync.exr" 2>"$work/$n.sync.stderr" &&
    echo "      with TESSERA_SYNC_LAUNCHES=1 it rendered (a failure that depends on timing)" ||
    echo "      with TESSERA_SYNC_LAUNCHES=1: $(grep -v '^ ' "$work/$n.sync.stderr" | tail -1)"
done
if [ "$failed" -gt 0 ]; then
  echo "check_device: $failed of ${#renders[@]} renders failed on device $device${out:+ (stderr in $out)}"
  exit 1
fi
echo "check_device: all $((${#renders[@]} - skipped)) renders succeeded on device $device$([ "$skipped" -gt 0 ] && echo " ($skipped skipped)")"
