#!/usr/bin/env bash
# Developer helper: builds targets in the shared ./build folder, one build at a time
# (several people may share one working tree). Usage: scripts/dev-build.sh [target...]
set -euo pipefail
cd "$(dirname "$0")/.."
exec 9>/tmp/storey-build.lock
flock 9
if [ ! -f build/build.ninja ]; then
  cmake --preset dev -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >/dev/null
fi
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build build --parallel 2 "${targets[@]}"
