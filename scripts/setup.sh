#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine for storey and builds it: installs the Debian
# packages that are missing, configures (once) and builds into ./build. Idempotent:
# a second run installs nothing and rebuilds only what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake g++ ninja-build pkg-config ccache
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  libeigen3-dev liboctomap-dev libsuitesparse-dev libyaml-cpp-dev
  libsqlite3-dev zlib1g-dev libzstd-dev liblz4-dev
  libgtest-dev libgmock-dev libbenchmark-dev libceres-dev
  iproute2 openssl
)
source scripts/packages.sh
ensure_packages "${packages[@]}"

build_dir=${STOREY_BUILD_DIR:-build}
if [ ! -f "$build_dir/build.ninja" ]; then
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  # The release preset (CMakePresets.json): a unity build (several sources per compiler
  # run) builds from scratch in about two thirds of the time.
  cmake --preset release -B "$build_dir" "${launcher[@]}" ${STOREY_CMAKE_ARGS:-}
fi
cmake --build "$build_dir" --parallel "$(nproc)"
