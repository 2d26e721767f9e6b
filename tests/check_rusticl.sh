#!/usr/bin/env bash
# tests/check_rusticl.sh BUILD_DIR — the kernels on a second OpenCL implementation: Mesa's
# Rusticl on llvmpipe (Debian's mesa-opencl-icd, tools/setup.sh), a different compiler from
# PoCL's. Three checks on the Rusticl device:
#   1. tools/check_device.sh: every stage and kernel path renders;
#   2. test_shading_normal on it: shade's normals equal the host's bit for bit (the check that
#      caught Mesa 22.3 miscompiling bezier_combine's float4 form, issue 40);
#   3. scene/teapot.rib and scene/lama.rib (translucent sheets, a clear coat, cut-outs) at
#      160x90 x 4, and scene/teapot_displaced.rib squeezed (--lod 5 --memory 1: its patches
#      do not fit, most are diced again without their vertices, top_level marks the patches
#      rays leave) on Rusticl against PoCL: RMSE of the 8-bit PNGs at most 1.5 levels (devices
#      may differ in the last bits of their transcendental functions).
# Skipped (77) where Rusticl or PoCL lists no device (RUSTICL_ENABLE=llvmpipe is set here
# unless already set). The first run builds the kernels on llvmpipe, a minute or two; later
# runs take them from the kernel cache.
set -uo pipefail
build=$1
src=$(cd "$(dirname "$0")/.." && pwd)
bin=${TESSERA_BINARY:-$build/tessera}
export RUSTICL_ENABLE=${RUSTICL_ENABLE:-llvmpipe}
# `tessera devices`: "I: NAME [...]" then "   platform PLATFORM, driver ...".
device_of() {
    "$bin" devices 2>/dev/null |
        awk -v want="$1" '/^[0-9]+: /{i=$1; sub(":", "", i)} /^ *platform /{if (index($0, "platform " want ",")) {print i; exit}}'
}
rc_dev=$(device_of rusticl)
pocl_dev=$(device_of "Portable Computing Language")
if [ -z "$rc_dev" ] || [ -z "$pocl_dev" ]; then
    echo "check_rusticl: no Rusticl (mesa-opencl-icd) or no PoCL device listed: skipping"
    exit 77
fi
echo "check_rusticl: Rusticl is device $rc_dev, PoCL device $pocl_dev"
bash "$src/tools/check_device.sh" --build "$build" --device "$rc_dev" ||
    { echo "check_rusticl: tools/check_device.sh failed on Rusticl"; exit 1; }
TESSERA_DEVICE=$rc_dev TESSERA_SOURCE_DIR=$src "$build/tests/test_shading_normal" ||
    { echo "check_rusticl: test_shading_normal failed on Rusticl"; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/check-rusticl-XXXXXX")
trap 'rm -rf "$work"' EXIT
# The teapot, scene/lama.rib (translucent sheets, a clear coat, cut-outs from a mask), and the
# displaced teapot in a budget its patches do not fit (the squeezed frame's own paths: the
# leaving marks, trees built without a grid, patches diced again).
for scene in teapot lama squeezed; do
    file=$scene args=()
    [ "$scene" = squeezed ] && file=teapot_displaced args=(--lod 5 --memory 1)
    for d in "$pocl_dev" "$rc_dev"; do
        "$bin" render "$src/scene/$file.rib" --res 160x90 --spp 4 "${args[@]}" --quiet \
            --device "$d" -o "$work/$scene-$d.png" --stats "$work/$scene-$d.json" ||
            { echo "check_rusticl: $scene failed on device $d"; exit 1; }
    done
    if [ "$scene" = squeezed ]; then # still the regime it is here for, on both devices
        python3 "$src/tools/check_squeezed.py" "$work/$scene-$pocl_dev.json" \
            "$work/$scene-$rc_dev.json" || exit 1
    fi
    python3 - "$src/tools/bench_cycles.py" "$work/$scene-$pocl_dev.png" "$work/$scene-$rc_dev.png" \
        "$scene" <<'EOF' || exit 1
import importlib.util, math, sys
spec = importlib.util.spec_from_file_location("bench_cycles", sys.argv[1])
png = importlib.util.module_from_spec(spec)
spec.loader.exec_module(png)
w, h, a = png.png_read(sys.argv[2])
w2, h2, b = png.png_read(sys.argv[3])
assert (w, h) == (w2, h2) == (160, 90), "the images differ in size"
ss = sum((ra[i] - rb[i]) ** 2 for ra, rb in zip(a, b) for i in range(3 * w))
rmse = math.sqrt(ss / (3 * w * h))
print(f"check_rusticl: {sys.argv[4]} 160x90 x 4, Rusticl vs PoCL: RMSE {rmse:.3f} levels (limit 1.5)")
sys.exit(0 if rmse <= 1.5 else 1)
EOF
done
