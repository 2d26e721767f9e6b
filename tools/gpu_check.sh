#!/usr/bin/env bash
# tools/gpu_check.sh — everything a GPU loan should check, in one command and one report
# (issue 40 item 6; docs/building.md "A GPU check in one command").
#
#   tools/gpu_check.sh pack [BUILD_DIR]
#       here, on the build machine: tools/bundle.sh's bundle of BUILD_DIR (default build) as
#       bundle/tessera-bundle.tar.xz (about 20 MB), and the reference images rendered on PoCL
#       in bundle/gpu-check/ with the commit they come from. bundle/ is ignored by git: carry
#       it to the GPU machine with the checkout (the device tool's `carry`, or rsync).
#   tools/gpu_check.sh run OUT_DIR [--device I] [--quick]
#       there, in a checkout of the same commit with bundle/ (no build dependencies needed):
#       1. `tessera devices`, and the device checked: --device I, else the first GPU listed;
#       2. tools/check_device.sh on it (every stage and kernel path renders);
#       3. the kernel and renderer tests that compare with the C references, on it
#          (TESSERA_DEVICE=I);
#       4. images against PoCL's references: RMSE of the 8-bit PNGs, limit 1.5 levels
#          (devices differ in the last bits of their transcendental functions);
#       5. the benchmark rows of issue 40: teapot_displaced 1280x720 x 16 (three runs) and,
#          unless --quick, forest-100 1920x768 x 32 (two runs), on the GPU alone, with
#          --streams 2, then with the first CPU device listed beside it (--device GPU,CPU)
#          when there is one; unless --quick, issue 38's cliff on the GPU alone (forest-100
#          1920x768 x 2 as it fits and at --memory 512, one run each): wall,
#          kernel_seconds / wall (how busy the devices were), host_serial_seconds, sort.
#       Writes OUT_DIR/gpu-check.md (the report), and beside it each step's log, the images
#       and the --stats files. Exit status 0 when steps 2-4 passed, 1 when one failed, 2 bad
#       usage, 77 no GPU (and no --device).
# The whole run takes about 4 minutes on an H200 with a cold kernel cache (the first render
# builds the kernels); --quick leaves out forest-100, about 1 minute less.
set -uo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
cd "$src" || exit 2
usage() { sed -n '2,30p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
# name|scene|arguments of the images compared with PoCL's
images=(
  "teapot|scene/teapot.rib|--res 160x90 --spp 4"
  "teapot_displaced|scene/teapot_displaced.rib|--res 320x180 --spp 4"
  "forest-1|scene/forest-1.rib|--res 480x192 --spp 2"
  "lights|scene/lights.rib|--res 160x90 --spp 4"
  "motion|scene/motion.rib|--res 160x90 --spp 4"
  "instances|scene/instances_displaced.rib|--res 160x90 --spp 2"
  "small_budget|scene/teapot_displaced.rib|--res 160x90 --spp 4 --memory 32"
)

pack() {
  local build=${1:-build}
  [ -x "$build/tessera" ] || { echo "gpu_check: $build/tessera is not built (tools/setup.sh)" >&2; exit 2; }
  rm -rf bundle
  mkdir -p bundle
  bash tools/bundle.sh make "$build" bundle/tessera-bundle.tar.xz >/dev/null || exit 1
  local ref=bundle/gpu-check
  mkdir -p "$ref"
  git rev-parse HEAD >"$ref/commit" 2>/dev/null || echo unknown >"$ref/commit"
  git status --porcelain --untracked-files=no | grep -q . && echo "(with uncommitted changes)" >>"$ref/commit"
  "$build/tessera" devices | head -3 >"$ref/device"
  local pocl
  pocl=$("$build/tessera" devices 2>/dev/null |
    awk '/^[0-9]+: /{i=$1; sub(":", "", i)} /^ *platform Portable Computing Language,/{print i; exit}')
  [ -n "$pocl" ] || { echo "gpu_check: pack needs PoCL here for the reference images" >&2; exit 1; }
  for r in "${images[@]}"; do
    IFS='|' read -r name scene args <<<"$r"
    # shellcheck disable=SC2086 # the arguments are words
    "$build/tessera" render "$scene" $args --device "$pocl" --quiet -o "$ref/$name.png" ||
      { echo "gpu_check: the reference $name failed on PoCL" >&2; exit 1; }
  done
  echo "gpu_check: bundle/ packed ($(du -sh bundle | cut -f1)) with ${#images[@]} PoCL references of $(head -1 "$ref/commit")"
  echo "gpu_check: there, in a checkout of this commit with bundle/: tools/gpu_check.sh run OUT_DIR"
}

# tessera ARGS...: the bundle's, with its libraries and its kernel cache (bundle/run.sh)
tess() { bash "$src/bundle/run.sh" tessera "$@"; }

# `tessera devices` lines "I: NAME [TYPE, VERSION]": the index of the first of TYPE.
first_of_type() { tess devices 2>/dev/null | sed -n "s/^\([0-9]*\): .*\[$1, .*/\1/p" | head -1; }

# median of the numbers on stdin
median() { sort -g | awk '{v[NR] = $1} END {if (NR == 0) print "-"; else if (NR % 2) print v[(NR + 1) / 2]; else printf "%.3f\n", (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

# field FILE KEY [STAGE]: a number of a --stats file
field() {
  python3 - "$@" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
v = d["stages"][sys.argv[3]] if len(sys.argv) > 3 else d[sys.argv[2]]
print(f"{v:.3f}")
EOF
}

# bench LABEL DEVICES RUNS SCENE ARGS...: a row of the benchmark table
bench() {
  local label=$1 devices=$2 runs=$3 scene=$4
  shift 4
  local walls="" busy="" serial="" sort="" ok=0 file
  file=$(tr -c 'A-Za-z0-9_.\n-' '_' <<<"$label-$devices")
  for i in $(seq 1 "$runs"); do
    local s="$out/bench-$file-$i.json"
    if tess render "$scene" "$@" --device "$devices" --quiet -o "$out/bench-$file.exr" \
      --stats "$s" 2>>"$out/bench.log"; then
      ok=$((ok + 1))
      local w k
      w=$(field "$s" wall_seconds) k=$(field "$s" kernel_seconds)
      walls+="$w " busy+="$(awk -v k="$k" -v w="$w" 'BEGIN {printf "%.2f", k / w}') "
      serial+="$(field "$s" host_serial_seconds) " sort+="$(field "$s" x sort) "
    fi
  done
  m() { tr ' ' '\n' <<<"$1" | grep . | median; }
  printf '| %s | %s | %s | %s (%s) | %s | %s | %s |\n' "$label" "$devices" "$ok/$runs" \
    "$(m "$walls")" "${walls% }" "$(m "$busy")" "$(m "$serial")" "$(m "$sort")" >>"$report"
}

run() {
  out=${1:-}
  [ -n "$out" ] || usage
  shift
  local device="" quick=0
  while [ $# -gt 0 ]; do
    case $1 in
    --device) device=${2:?--device takes an index}; shift 2 ;;
    --quick) quick=1; shift ;;
    *) echo "gpu_check: unknown argument '$1' (--help)" >&2; exit 2 ;;
    esac
  done
  if [ ! -x bundle/run.sh ] && [ -f bundle/tessera-bundle.tar.xz ]; then
    tar xJf bundle/tessera-bundle.tar.xz -C "$src" || exit 2
  fi
  [ -x bundle/run.sh ] || { echo "gpu_check: no bundle/ here: run 'tools/gpu_check.sh pack' on the build machine first" >&2; exit 2; }
  mkdir -p "$out" || exit 2
  out=$(cd "$out" && pwd)
  report=$out/gpu-check.md
  tess devices >"$out/devices.txt" 2>&1
  [ -n "$device" ] || device=$(first_of_type GPU)
  if [ -z "$device" ]; then
    echo "gpu_check: no GPU in 'tessera devices' (and no --device): skipping" | tee "$report"
    cat "$out/devices.txt"
    exit 77
  fi
  local cpu
  cpu=$(first_of_type CPU)
  [ "$cpu" = "$device" ] && cpu="" # a CPU checked as the device has none beside it
  local name
  name=$(sed -n "s/^$device: //p" "$out/devices.txt")
  local failed=0 t0=$SECONDS
  {
    echo "# GPU check, $(date -u '+%Y-%m-%d %H:%M UTC')"
    echo
    echo "Commit $(head -1 bundle/gpu-check/commit 2>/dev/null || echo unknown); device $device: $name."
    echo "References: PoCL on $(head -1 bundle/gpu-check/device 2>/dev/null | sed 's/^[0-9]*: //')."
    echo
    echo '```'
    cat "$out/devices.txt"
    echo '```'
    echo
  } >"$report"

  echo "gpu_check: 2. tools/check_device.sh on device $device"
  if bash bundle/run.sh tools/check_device.sh --device "$device" --out "$out/check_device" \
    >"$out/check_device.log" 2>&1; then
    echo "## check_device: passed" >>"$report"
  else
    failed=1
    echo "## check_device: FAILED" >>"$report"
  fi
  { echo; echo '```'; grep -v '^ *$' "$out/check_device.log" | tail -20; echo '```'; echo; } >>"$report"

  echo "gpu_check: 3. the kernel and renderer tests on device $device"
  local tests='test_(trace|bottom_level|top_level|dice_build|shading_normal|layout|leaf_modes|pathtrace|failure|embree|box_vs_triangles|sampler|lights)$'
  if TESSERA_DEVICE=$device bash bundle/run.sh ctest -j "$(nproc)" -R "$tests" \
    >"$out/ctest.log" 2>&1; then
    echo "## Tests against the C references: passed" >>"$report"
  else
    failed=1
    echo "## Tests against the C references: FAILED" >>"$report"
  fi
  { echo; echo '```'; grep -E 'Test +#|tests passed|tests failed' "$out/ctest.log" | tail -20; echo '```'; echo; } >>"$report"

  echo "gpu_check: 4. images against PoCL's"
  { echo "## Images against PoCL's (RMSE of the 8-bit PNGs, limit 1.5 levels)"; echo
    echo "| image | arguments | RMSE | |"; echo "|---|---|---:|---|"; } >>"$report"
  for r in "${images[@]}"; do
    IFS='|' read -r name scene args <<<"$r"
    local verdict rmse="-"
    # shellcheck disable=SC2086 # the arguments are words
    if tess render "$scene" $args --device "$device" --quiet -o "$out/$name.png" \
      2>"$out/$name.stderr"; then
      rmse=$(python3 - "$src/tools/bench_cycles.py" "bundle/gpu-check/$name.png" "$out/$name.png" <<'EOF'
import importlib.util, math, sys
spec = importlib.util.spec_from_file_location("bench_cycles", sys.argv[1])
png = importlib.util.module_from_spec(spec)
spec.loader.exec_module(png)
w, h, a = png.png_read(sys.argv[2])
w2, h2, b = png.png_read(sys.argv[3])
if (w, h) != (w2, h2):
    print("size")
else:
    ss = sum((ra[i] - rb[i]) ** 2 for ra, rb in zip(a, b) for i in range(3 * w))
    print(f"{math.sqrt(ss / (3 * w * h)):.3f}")
EOF
)
      if awk -v r="$rmse" 'BEGIN {exit !(r + 0 == r && r <= 1.5)}'; then verdict=ok; else verdict=FAIL; failed=1; fi
    else
      verdict="FAIL: $(grep -v '^ ' "$out/$name.stderr" | tail -1)"
      failed=1
    fi
    echo "| $name | \`$args\` | $rmse | $verdict |" >>"$report"
  done
  echo >>"$report"

  echo "gpu_check: 5. benchmark rows"
  { echo "## Benchmarks (warm kernel cache; busy = kernel_seconds / wall)"; echo
    echo "| scene | devices | runs | wall s, median (runs) | busy | host_serial s | sort s |"
    echo "|---|---|---:|---:|---:|---:|---:|"; } >>"$report"
  bench teapot_displaced "$device" 3 scene/teapot_displaced.rib --res 1280x720 --spp 16
  bench "teapot_displaced --streams 2" "$device" 3 scene/teapot_displaced.rib --res 1280x720 --spp 16 --streams 2
  [ -n "$cpu" ] && bench teapot_displaced "$device,$cpu" 2 scene/teapot_displaced.rib --res 1280x720 --spp 16
  if [ "$quick" = 0 ]; then
    bench forest-100 "$device" 2 scene/forest-100.rib --res 1920x768 --spp 32
    bench "forest-100 --streams 2" "$device" 2 scene/forest-100.rib --res 1920x768 --spp 32 --streams 2
    [ -n "$cpu" ] && bench forest-100 "$device,$cpu" 1 scene/forest-100.rib --res 1920x768 --spp 32
    # issue 38's cliff on the GPU: the frame that fits, and squeezed to 512 MB (its patches 15
    # times the arenas: thousands of batches an iteration, at most four of them queued)
    bench "forest-100 x 2" "$device" 1 scene/forest-100.rib --res 1920x768 --spp 2
    bench "forest-100 x 2 --memory 512" "$device" 1 scene/forest-100.rib --res 1920x768 --spp 2 --memory 512
  fi
  { echo
    echo "The rows' --stats files are bench-LABEL-DEVICES-RUN.json beside this report; check_device's"
    echo "images and messages are in check_device/, the tests' output in ctest.log."
    echo
    echo "Took $((SECONDS - t0)) s: \`tools/gpu_check.sh run OUT_DIR --device $device\`."; } >>"$report"
  if [ "$failed" = 0 ]; then echo "gpu_check: passed; report $report"; else echo "gpu_check: FAILED; report $report"; fi
  return "$failed"
}

case "${1:-}" in
pack) shift; pack "$@" ;;
run) shift; run "$@"; exit $? ;;
*) usage ;;
esac
