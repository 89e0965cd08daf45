#!/usr/bin/env bash
# Sets up and builds storey (scripts/setup.sh), checks the format of the changed lines
# (scripts/format-check.sh) and runs clang-tidy on the changed sources (scripts/tidy.sh;
# on main both look at what the newest commit changed), then runs every test: unit tests (core,
# no DDS), integration tests (components over DDS on loopback, several processes, two
# network namespaces), scenario tests (the whole pipeline on simulated buildings and real
# logs); then the sanitizer runs (scripts/sanitize.sh: unit tests under ASan + UBSan, the
# runtime's tests under TSan) and a short run of every fuzz target (scripts/fuzz.sh).
# STOREY_SANITIZERS=0 skips the last two (a quicker local run); CI runs everything.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
# The independent DDS peer of the interoperability test (tests/interop) and the browser
# of the report test (tests/browser), not dependencies of storey itself: installed before
# the build configures.
source scripts/packages.sh
ensure_packages cyclonedds-dev cyclonedds-tools chromium-headless-shell
./scripts/setup.sh
echo "== build: $((SECONDS - start)) s"
build_dir=${STOREY_BUILD_DIR:-build}
status=0
echo "== format"
./scripts/format-check.sh || status=1
echo "== clang-tidy"
phase_start=$SECONDS
./scripts/tidy.sh || status=1
echo "== clang-tidy: $((SECONDS - phase_start)) s"
for label in unit integration scenario; do
  echo "== $label tests"
  phase_start=$SECONDS
  # DDS tests use distinct domain ids, so they can run in parallel.
  ctest --test-dir "$build_dir" -L "^${label}\$" --output-on-failure --parallel "$(nproc)" \
    --no-tests=ignore || status=1
  echo "== $label tests: $((SECONDS - phase_start)) s"
done
if [ "${STOREY_SANITIZERS:-1}" != 0 ]; then
  echo "== sanitizers"
  phase_start=$SECONDS
  ./scripts/sanitize.sh asan tsan || status=1
  echo "== sanitizers: $((SECONDS - phase_start)) s"
  echo "== fuzzing, ${STOREY_FUZZ_SECONDS:-10} s per target"
  phase_start=$SECONDS
  ./scripts/fuzz.sh "${STOREY_FUZZ_SECONDS:-10}" || status=1
  echo "== fuzzing: $((SECONDS - phase_start)) s"
fi
echo "== total: $((SECONDS - start)) s, $([ $status -eq 0 ] && echo passed || echo FAILED)"
exit $status
