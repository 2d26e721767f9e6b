#!/usr/bin/env bash
# tools/check_kernels.sh — runs every OpenCL kernel under Oclgrind on tiny inputs and fails on
# any report: out-of-bounds access, data race (global or local memory), read of uninitialised
# memory, OpenCL API error, or an Oclgrind internal error. Also fails when a __kernel in
# kernels/*.cl was never launched, so a new kernel must get a run here (a unit test that
# opens the device, or a render below). Registered as the ctest test `check_kernels`.
#
# Usage: tools/check_kernels.sh [BUILD_DIR]      (default $BUILD_DIR, else build; must be built)
# Environment: CHECK_KERNELS_TIMEOUT  seconds per program (default 240: a hang, not a slow
#                                      machine; test_relight_kernels took over 120 s on a loaded Xeon)
#              CHECK_KERNELS_KEEP=1   keep the work directory (logs) after a pass too
# Exit status: 0 clean, 1 a report / a failing program / a kernel never launched,
#              77 oclgrind is not installed (ctest: skipped).
#
# What runs, each under `oclgrind --data-races --uninitialized --check-api` (the displaced
# teapot without --uninitialized, below):
#   - `tessera render` of scene/teapot.rib at 16x9, 2 spp, --max-lod 3, and of
#     scene/one_patch.rib at 8x8, --max-lod 0, both with --memory 4 (the whole pipeline,
#     every stage);
#   - the teapot at 16x9, --lod 4, --memory 2 (its patches do not fit: top_level's leaving
#     marks, dice over part of a batch's trees, trees built without vertices);
#   - the same teapot with --leaf-mode group --leaf-size 2 (the work-group leaf kernel);
#   - scene/textured.rib at 8x6, --max-lod 2 (image textures: displacement and colour);
#   - scene/lights.rib at 8x6, --max-lod 1 (point, spot and ambient lights in shade);
#   - scene/lama.rib at 8x6, --max-lod 1 (translucent sheets and a clear coat in shade);
#   - scene/teapot.rib at 7x5, 3 spp, with TESSERA_CPU_LANES=1 (the CPU devices' lanes:
#     camera's eight rays a work-item, bezier_combine's float4 sums), without --uninitialized;
#   - scene/depth_of_field.rib at 12x8 cropped to 6x4 (the thin lens, the crop), in both
#     camera forms (the lanes without --uninitialized);
#   - scene/trimmed.rib at 8x6 in both geometry modes (trim curves in build and bottom_level);
#   - scene/teapot_displaced.rib at 12x8, --max-lod 4, --depth 2 (displacement, the grid's
#     shading normals, bounce rays), and at 8x6 with --intersect triangles (the tight leaf
#     boxes), both without --uninitialized;
#   - `tessera bake` of the teapot and of textured.rib (tiles paged) at tiny sizes (the
#     bake kernels; test_bake_kernels traces waves of the teapot, minutes under Oclgrind);
#   - every test program whose source calls test_open_device() (the kernel unit tests),
#     except SLOW_TESTS (whole-renderer comparisons, minutes under Oclgrind; the renders
#     above run the same kernels).
# The programs open device 0 of the first platform; under Oclgrind's runtime (preloaded by
# the `oclgrind` wrapper) that platform is Oclgrind's and no other, which the launch log
# below confirms for every launch.
#
# Two details, both for Oclgrind 21.10 (Debian 12):
#   - kernels are built with -cl-opt-disable (--build-options): with optimisation, clang
#     emits LLVM `freeze` instructions that its --uninitialized plugin does not support
#     ("OCLGRIND FATAL ERROR ... Unsupported instruction: freeze"), which aborts the kernel
#     and then reports false uninitialised reads downstream;
#   - tools/oclgrind_host_writes.c is preloaded in front of Oclgrind's runtime: it makes
#     partial host writes, fills and read-write mappings visible to --uninitialized (see the
#     file), and logs every program build and kernel launch to $TESSERA_LAUNCH_LOG, which
#     is how coverage is checked (independent of Oclgrind's output format).
set -uo pipefail
cd "$(dirname "$0")/.."
src=$PWD
build=$(cd "${1:-${BUILD_DIR:-build}}" 2>/dev/null && pwd) || { echo "check_kernels: no build directory ${1:-${BUILD_DIR:-build}} (run tools/setup.sh)" >&2; exit 1; }
timeout_s=${CHECK_KERNELS_TIMEOUT:-240}
SLOW_TESTS="test_trace test_embree test_leaf_modes test_bottom_level test_box_vs_triangles test_kernel_cache test_bake_kernels"

if ! command -v oclgrind >/dev/null; then
  echo "check_kernels: oclgrind is not installed (apt-get install oclgrind): skipping"
  exit 77
fi
if grep -q '^TESSERA_SANITIZE:BOOL=ON' "$build/CMakeCache.txt" 2>/dev/null; then
  # ASan must come first in the preload list, Oclgrind's runtime must too: checked in the plain build.
  echo "check_kernels: sanitizer build: skipping (the plain build runs this check)"
  exit 77
fi
[ -x "$build/tessera" ] || { echo "check_kernels: $build/tessera not built" >&2; exit 1; }

work=$(mktemp -d "${TMPDIR:-/tmp}/check-kernels-XXXXXX")
shim=$work/liboclgrind_host_writes.so
cc -O2 -shared -fPIC -o "$shim" tools/oclgrind_host_writes.c -ldl || { echo "check_kernels: cannot build the shim" >&2; exit 1; }
export TESSERA_LAUNCH_LOG=$work/launches.tsv TESSERA_CHECK_SHIM=$shim
export TESSERA_CACHE_DIR=$work/kernel-cache # nothing built elsewhere is loaded
export TESSERA_SOURCE_DIR=$src TESSERA_BINARY=$build/tessera TESSERA_SHARED_DIR=$src/../shared
unset TESSERA_DEVICE
: >"$TESSERA_LAUNCH_LOG"

# Lines Oclgrind writes about a problem, in case any reach the program's output rather than
# the --log file (every line of the --log file counts as a report anyway).
report_re='OCLGRIND|Oclgrind - |Invalid (read|write)|[Dd]ata race|Uninitiali[sz]ed (value|address)|[Dd]ivergence|Entity: |errors generated'

failed=0
t_start=$SECONDS
# run NAME PROGRAM [ARGS...]: one program under Oclgrind; its log, output and status checked.
run() {
  local name=$1; shift
  local log=$work/$name.oclgrind.log out=$work/$name.out t0=$SECONDS rc
  timeout "$timeout_s" oclgrind ${OCLGRIND_CHECKS:---data-races --uninitialized --check-api} \
    --build-options -cl-opt-disable --log "$log" \
    sh -c 'LD_PRELOAD="$TESSERA_CHECK_SHIM${LD_PRELOAD:+:$LD_PRELOAD}"; export LD_PRELOAD; exec "$@"' \
    sh "$@" >"$out" 2>&1
  rc=$?
  local bad=""
  [ "$rc" -eq 124 ] && bad="did not finish in ${timeout_s} s under Oclgrind (give it a smaller input or add it to SLOW_TESTS)"
  [ -z "$bad" ] && [ "$rc" -ne 0 ] && bad="exit status $rc"
  if [ -s "$log" ]; then
    # A report starts with an unindented line; its details are indented.
    bad="${bad:+$bad; }$(grep -c '^[^[:space:]]' "$log") Oclgrind report(s)"
  fi
  if grep -Eq "$report_re" "$out"; then bad="${bad:+$bad; }Oclgrind report(s) in its output"; fi
  if [ -n "$bad" ]; then
    echo "FAIL  $name ($((SECONDS - t0)) s): $bad"
    echo "----- $name: Oclgrind log ($log), first 60 lines"
    [ -s "$log" ] && head -n 60 "$log"
    echo "----- $name: program output, last 30 lines"
    tail -n 30 "$out"
    echo "-----"
    failed=1
  else
    echo "ok    $name ($((SECONDS - t0)) s)"
  fi
}

# --memory 4: small buffers; Oclgrind's checkers cost time per byte of buffer, not only per
# work-item (the default budget makes the same render ~6x slower).
run render_teapot "$build/tessera" render scene/teapot.rib --res 16x9 --spp 2 --max-lod 3 \
  --memory 4 -o "$work/teapot.exr" --no-kernel-cache --quiet
run render_one_patch "$build/tessera" render scene/one_patch.rib --res 8x8 --max-lod 0 \
  --memory 4 -o "$work/one_patch.exr" --no-kernel-cache --quiet
# A frame whose patches do not fit (one eviction at --memory 2): top_level marks the patches
# rays leave (atomic_xchg), dice runs over each m's first trees only, build without vertices.
run render_squeezed "$build/tessera" render scene/teapot.rib --res 16x9 --spp 1 --lod 4 \
  --memory 2 -o "$work/squeezed.exr" --stats "$work/squeezed.json" --no-kernel-cache --quiet
# ... and still that regime, or the run above checks a frame that fits.
if ! python3 tools/check_squeezed.py "$work/squeezed.json"; then
  echo "FAIL  render_squeezed: its patches fit (no eviction, or no tree built without vertices)"
  failed=1
fi
# The work-group leaf intersection (bottom_level_group, local memory and barriers): leaf
# blocks of 2x2, so work-items of one group share tasks.
run render_leaf_group "$build/tessera" render scene/teapot.rib --res 16x9 --spp 1 --max-lod 3 \
  --memory 4 -o "$work/leaf_group.exr" --no-kernel-cache --quiet --leaf-mode group --leaf-size 2
# Image textures: displacement (dice, build leaf bounds from the min-max pyramid, the
# shading normal) and colour (shade) through the page table and tile pool.
run render_textured "$build/tessera" render scene/textured.rib --res 8x6 --spp 1 --max-lod 2 \
  --memory 4 -o "$work/textured.exr" --no-kernel-cache --quiet
# Point, spot and ambient lights (light_sample, light_escape's eye rays) in shade.
run render_lights "$build/tessera" render scene/lights.rib --res 8x6 --spp 2 --max-lod 1 \
  --memory 4 -o "$work/lights.exr" --no-kernel-cache --quiet
# Translucent sheets, a clear coat and an emitting mix (scene/lama.rib: shade's light samples
# and rays through a sheet, from its far side, and the principled coat).
run render_lama "$build/tessera" render scene/lama.rib --res 8x6 --spp 2 --max-lod 1 --depth 3 \
  --memory 4 -o "$work/lama.exr" --no-kernel-cache --quiet
# The bake (kernels/bake.cl: points, rays, SH projection) through the pipeline, every patch
# at m = 1, two rays per point; textured.rib's tiles are paged at 4 MB (bake_points in
# ranges).
run bake_teapot "$build/tessera" bake scene/teapot.rib --lod 1 --rays 2 \
  --memory 4 -o "$work/bake.exr" --no-kernel-cache --quiet
run bake_textured "$build/tessera" bake scene/textured.rib --res 8x6 --rays 4 --max-lod 2 \
  --memory 4 -o "$work/bake_textured.exr" --no-kernel-cache --quiet
# The CPU devices' lanes (-DTS_CPU_LANES, forced with TESSERA_CPU_LANES=1 on Oclgrind's
# device, which is a GPU): camera_generate's eight rays a work-item, with a last work-item of
# fewer (105 rays), and bezier_combine's float4 sums. --uninitialized left out as below
# (float8 lanes).
TESSERA_CPU_LANES=1 OCLGRIND_CHECKS="--data-races --check-api" \
  run render_cpu_lanes "$build/tessera" render scene/teapot.rib --res 7x5 --spp 3 --max-lod 2 \
  --depth 1 --memory 4 -o "$work/cpu_lanes.exr" --no-kernel-cache --quiet
# Skeletons (build_skeleton, bottom_level's bl_skeleton making the leaves a ray enters with the
# lanes' block_leaf_boxes, and the vertices of those leaving the patch): a squeezed frame, its
# skeletons' room taken from the arenas (budget.c skeleton_room), every segment that may taking
# one.
TESSERA_CPU_LANES=1 TESSERA_SKELETON_PAIR_LEAVES=1 \
  OCLGRIND_CHECKS="--data-races --check-api" \
  run render_skeleton "$build/tessera" render scene/teapot_displaced.rib --res 16x9 --spp 4 \
  --lod 4 --memory 1 -o "$work/skeleton.exr" --stats "$work/skeleton.json" --no-kernel-cache \
  --quiet
if ! python3 -c 'import json, sys; sys.exit(json.load(open(sys.argv[1]))["counters"]["skeleton_segments"] == 0)' \
  "$work/skeleton.json"; then
  echo "FAIL  render_skeleton: no segment went through a skeleton"
  failed=1
fi
# A thin lens and a part of the frame (DepthOfField, --crop): camera_generate's lens in both
# of its forms, the lod stage over the whole frame around the part.
run render_lens "$build/tessera" render scene/depth_of_field.rib --res 12x8 --spp 2 --max-lod 2 \
  --depth 1 --crop 0.25,0.75,0,0.5 --memory 4 -o "$work/lens.exr" --no-kernel-cache --quiet
TESSERA_CPU_LANES=1 OCLGRIND_CHECKS="--data-races --check-api" \
  run render_lens_lanes "$build/tessera" render scene/depth_of_field.rib --res 12x8 --spp 2 \
  --max-lod 2 --depth 1 --crop 0.25,0.75,0,0.5 --memory 4 -o "$work/lens_lanes.exr" \
  --no-kernel-cache --quiet
# The displaced teapot with bounce and shadow rays: fBm displacement in dice and build (the
# noise's float4 and float8 lanes), bottom_level over displaced leaf boxes and the origin
# patch's micro-triangles, and shade's micro-quad normals read from the diced grid where the
# patch is resident. Out-of-bounds, races and API checks only: Oclgrind 21.10's
# --uninitialized plugin crashes on the noise's float8 lanes (below).
OCLGRIND_CHECKS="--data-races --check-api" \
  run render_displaced "$build/tessera" render scene/teapot_displaced.rib --res 12x8 --spp 1 \
  --max-lod 4 --depth 2 --memory 8 -o "$work/displaced.exr" --no-kernel-cache --quiet
# The same in triangle mode: build's tight leaf boxes (the diced vertices' boxes).
OCLGRIND_CHECKS="--data-races --check-api" \
  run render_displaced_triangles "$build/tessera" render scene/teapot_displaced.rib --res 8x6 \
  --spp 1 --max-lod 3 --depth 1 --memory 8 --intersect triangles -o "$work/displaced_tri.exr" \
  --no-kernel-cache --quiet
# Trim curves (TrimCurve): build's empty boxes for the micro-quads a trim removes (the trim
# segments read per leaf), and bottom_level's check of them before a micro-quad's triangles.
run render_trimmed "$build/tessera" render scene/trimmed.rib --res 8x6 --spp 1 --max-lod 3 \
  --depth 1 --memory 4 -o "$work/trimmed.exr" --no-kernel-cache --quiet
run render_trimmed_triangles "$build/tessera" render scene/trimmed.rib --res 8x6 --spp 1 \
  --max-lod 3 --depth 1 --memory 4 --intersect triangles -o "$work/trimmed_tri.exr" \
  --no-kernel-cache --quiet
# The shading normal's probe (shade_normal_probe) on the teapot without displacement only:
# Oclgrind 21.10's --uninitialized plugin crashes (SIGSEGV in
# Uninitialized::instructionExecuted) on the fbm noise in float8 lanes (lib/noise4.h).
run test_shading_normal "$build/tests/test_shading_normal" test_plain
for f in tests/test_*.c; do
  t=$(basename "$f" .c)
  grep -q 'test_open_device' "$f" || continue
  case " $SLOW_TESTS " in *" $t "*) echo "skip  $t (SLOW_TESTS)"; continue ;; esac
  [ "$t" = test_shading_normal ] && continue # run above
  if [ ! -x "$build/tests/$t" ]; then echo "FAIL  $t: $build/tests/$t not built"; failed=1; continue; fi
  run "$t" "$build/tests/$t"
done

# Coverage: every kernel named in kernels/*.cl, or in a program that was built, was launched,
# and every launch ran on Oclgrind's device.
source_kernels=$(perl -0777 -ne 's{/\*.*?\*/}{}gs; s{//[^\n]*}{}g;
  print "$1\n" while /\b(?:__)?kernel\s+(?:__attribute__\s*\(\(.*?\)\)\s*)*void\s+(\w+)\s*\(/gs' kernels/*.cl | sort -u)
program_kernels=$(awk -F'\t' '$1 == "program" { n = split($2, k, ";"); for (i = 1; i <= n; i++) if (k[i] != "") print k[i] }' "$TESSERA_LAUNCH_LOG" | sort -u)
launched=$(awk -F'\t' '$1 == "launch" { print $2 }' "$TESSERA_LAUNCH_LOG" | sort -u)
devices=$(awk -F'\t' '$1 == "launch" { print $3 }' "$TESSERA_LAUNCH_LOG" | sort -u)
if [ -z "$program_kernels" ]; then
  echo "FAIL  no program build was logged (is the shim preloaded?)"; failed=1
fi
missing=$(comm -23 <(printf '%s\n' $source_kernels $program_kernels | sort -u) <(printf '%s\n' $launched))
if [ -n "$missing" ]; then
  echo "FAIL  kernels never launched under Oclgrind: $(echo $missing)"
  echo "      (launch each from a test that calls test_open_device(), or from a render above)"
  failed=1
fi
if [ "$devices" != "Oclgrind Simulator" ]; then
  echo "FAIL  launches ran on: $(echo "$devices" | paste -sd, -), expected only Oclgrind Simulator"; failed=1
fi
echo "kernels launched under Oclgrind ($(echo $launched | wc -w)): $(echo $launched)"
echo "check_kernels: $((SECONDS - t_start)) s"

if [ "$failed" -ne 0 ]; then
  echo "check_kernels: FAILED (logs kept in $work)"
  exit 1
fi
[ "${CHECK_KERNELS_KEEP:-0}" = 1 ] && echo "logs in $work" || rm -rf "$work"
echo "check_kernels: no Oclgrind reports"
