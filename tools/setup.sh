#!/usr/bin/env bash
# tools/setup.sh — installs the Debian 12 packages Tessera needs (only those missing), then
# configures and builds into build/. Used by tools/demo.sh and tools/test.sh.
# Environment: BUILD_DIR (default build), BUILD_TYPE (default RelWithDebInfo),
# CMAKE_ARGS (extra arguments for cmake, e.g. -DTESSERA_SANITIZE=ON).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake ninja-build gcc g++ pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers clinfo
  libopenimageio-dev libopenexr-dev libpng-dev libcjson-dev libcmocka-dev
  zlib1g-dev # gzip RIB (host/scene/rib/rib_text.c)
  libminizip-dev # archives inside zip files, "a.zip!b.rib" (host/scene/rib/rib_archive.c)
  libexpat1-dev # RenderMan for Maya's look files, .rlf (XML; host/scene/rib/rib_look.c)
  libxxhash-dev # the job hash --resume checks (host/app/resume.c)
  libopenmpi-dev openmpi-bin # several processes under mpirun (host/app/ranks_mpi.c, optional)
  mesa-opencl-icd # Rusticl: a second OpenCL implementation for kernel checks (tests/check_rusticl.sh)
  oclgrind clang libclang-rt-14-dev clang-format # checks: tools/check_kernels.sh, tools/fuzz.sh
                                                   # (libFuzzer runtime), tools/check_format.sh
  libembree-dev
  libassimp-dev assimp-testmodels
  python3 librsvg2-bin # benchmarks (tools/bench, tools/bench_*.py); tools/profile --png (rsvg-convert)
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "setup: run as root or install: ${missing[*]}" >&2; exit 1; }
    sudo=sudo
  fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

build_dir=${BUILD_DIR:-build}
# shellcheck disable=SC2086
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-RelWithDebInfo}" ${CMAKE_ARGS:-} >/dev/null
cmake --build "$build_dir" -j "$(nproc)"
