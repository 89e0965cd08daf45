#!/usr/bin/env bash
# Configures build-asan (once) with the asan preset (CMakePresets.json): clang, build type
# Sanitize, ASan + UBSan on every target,
# libFuzzer's coverage instrumentation on the libraries, tests and fuzz targets on,
# benchmarks off. scripts/sanitize.sh (unit tests) and scripts/fuzz.sh share it.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/packages.sh
ensure_packages clang cmake ninja-build
[ -f build-asan/build.ninja ] && grep -q 'CMAKE_CXX_COMPILER:.*clang' build-asan/CMakeCache.txt \
  && exit 0
rm -rf build-asan
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake --preset asan "${launcher[@]}" >/dev/null
