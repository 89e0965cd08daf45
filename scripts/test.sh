#!/usr/bin/env bash
# Sets up and builds storey (scripts/setup.sh), then runs every test: unit tests (core,
# no DDS), then integration tests (components over DDS on loopback), then scenario tests
# (the whole pipeline on simulated buildings and real logs).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
build_dir=${STOREY_BUILD_DIR:-build}
status=0
for label in unit integration scenario; do
  echo "== $label tests"
  # DDS tests use distinct domain ids, so they can run in parallel.
  ctest --test-dir "$build_dir" -L "^${label}\$" --output-on-failure --parallel "$(nproc)" \
    --no-tests=ignore || status=1
done
exit $status
