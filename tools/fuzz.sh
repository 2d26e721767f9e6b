#!/usr/bin/env bash
# tools/fuzz.sh — builds the libFuzzer harness for the RIB parser (tests/fuzz/fuzz_rib.c) with
# clang, ASan and UBSan into build-fuzz/, then fuzzes rib_parse_string for a bounded time.
# Fails (exit 1) on any crash, sanitizer report, leak, timeout or out-of-memory; the input
# that did it is left as build-fuzz/artifacts/{crash,leak,timeout,oom}-<sha1>. Make it a
# regression test: fix the parser, then copy the file into tests/fuzz/regressions/.
#
# Environment: FUZZ_SECONDS (default 60), FUZZ_BUILD_DIR (default build-fuzz).
# Extra arguments go to the fuzzer (e.g. -jobs=2, -only_ascii=1). To replay one input:
#   build-fuzz/fuzz_rib build-fuzz/artifacts/crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${FUZZ_SECONDS:-60}
build=${FUZZ_BUILD_DIR:-build-fuzz}

# clang and its libFuzzer runtime (Debian: clang, libclang-rt-14-dev) come with tools/setup.sh.
runtime_ok() {
  command -v clang >/dev/null && command -v clang++ >/dev/null &&
    [ -f "$(clang --print-runtime-dir 2>/dev/null)/libclang_rt.fuzzer-$(uname -m).a" ]
}
runtime_ok || tools/setup.sh
runtime_ok || { echo "fuzz: clang with the libFuzzer runtime is not installed" >&2; exit 1; }

CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DTESSERA_FUZZ=ON >/dev/null
cmake --build "$build" --target fuzz_rib -j "$(nproc)"

# Seeds: the scenes, the hand-written fragments and every regression input. New inputs that
# reach new code go to $build/corpus (kept between local runs, not committed). Scenes with a
# Procedural are left out: a 1 KB forest or mesh file expands into a million patches or
# runs Assimp on a model, seconds and a gigabyte per input, which would starve the parser of
# executions and trip the fuzzer's time and memory limits.
mkdir -p "$build/corpus" "$build/artifacts"
rm -rf "$build/seeds" && mkdir -p "$build/seeds"
for f in scene/*.rib; do grep -q 'Procedural' "$f" || cp "$f" "$build/seeds/"; done
echo "fuzz: rib_parse_string for ${seconds} s"
set +e
"$build/fuzz_rib" -max_len=65536 -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
  -error_exitcode=1 -timeout_exitcode=1 -print_final_stats=1 \
  -dict=tests/fuzz/rib.dict -artifact_prefix="$build/artifacts/" \
  "$@" "$build/corpus" "$build/seeds" tests/fuzz/corpus tests/fuzz/regressions 2>"$build/fuzz.log"
rc=$?
set -e
grep -E '^(#[0-9]+ +(INITED|DONE)|stat::(number_of_executed_units|new_units_added|peak_rss_mb))' "$build/fuzz.log" || true
if [ "$rc" -ne 0 ]; then
  echo "fuzz: FAILED (exit $rc); the fuzzer's report:"
  grep -v -E '^#[0-9]+ +(NEW|REDUCE|pulse)' "$build/fuzz.log" | tail -n 80
  echo "fuzz: inputs left in $build/artifacts/:"
  ls -l "$build/artifacts/"
  echo "fuzz: replay with $build/fuzz_rib $build/artifacts/<file>; once fixed, copy it to tests/fuzz/regressions/"
  exit 1
fi
echo "fuzz: no crash in ${seconds} s"
