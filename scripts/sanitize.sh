#!/usr/bin/env bash
# Builds and runs the tests under sanitizers (STOREY_SANITIZE, build type Sanitize):
#   asan: build-asan, clang with ASan + UBSan (errors abort) and libFuzzer's coverage
#         instrumentation, so the same build holds the fuzz targets (scripts/fuzz.sh):
#         every unit test executable, run with ctest -L unit (less two heavy tests, below).
#   tsan: build-tsan, gcc with TSan: the runtime's and security's integration tests.
# Usage: scripts/sanitize.sh [asan] [tsan]   (default: both). Installs clang when missing,
# prints the time of each phase. Builds take the shared build lock (scripts/dev-build.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/packages.sh
modes=("$@")
[ ${#modes[@]} -eq 0 ] && modes=(asan tsan)
status=0

# Every storey_test(NAME x LABEL unit ...) of tests/unit and tests/fuzz.
unit_targets() {
  grep -ho 'storey_test(NAME [A-Za-z0-9_]* LABEL unit' tests/unit/*/CMakeLists.txt \
    tests/fuzz/CMakeLists.txt | awk '{print $2}'
}

build() {  # folder targets...
  local dir=$1
  shift
  local args=()
  for t in "$@"; do args+=(--target "$t"); done
  (
    exec 9>/tmp/storey-build.lock
    flock 9
    cmake --build "$dir" --parallel "$(nproc)" "${args[@]}"
  )
}

phase() {  # name command...
  local name=$1
  shift
  local start=$SECONDS
  if "$@"; then
    echo "sanitize.sh: $name: ok in $((SECONDS - start)) s"
  else
    echo "sanitize.sh: $name: FAILED after $((SECONDS - start)) s"
    status=1
  fi
}

for mode in "${modes[@]}"; do
  case $mode in
    asan)
      scripts/configure-asan.sh
      export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
      export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
      mapfile -t targets < <(unit_targets)
      phase "asan build (${#targets[@]} unit test executables)" build build-asan "${targets[@]}"
      # Two unit tests repeat code paths the others cover, many times over: under ASan
      # they took 190 of the 400 test seconds (CI must stay under 30 minutes). They run in
      # the plain unit run as always.
      phase "asan unit tests" ctest --test-dir build-asan -L '^unit$' --output-on-failure \
        --parallel "$(nproc)" \
        -E '^(FloorSessions\.SymmetricFloorGivesANewGraphNotAWrongTie|FloorSlam\.LoopClosureCorrectsDrift)$'
      ;;
    tsan)
      ensure_packages g++ cmake ninja-build
      if [ ! -f build-tsan/build.ninja ]; then
        cmake --preset tsan >/dev/null
      fi
      # Fast DDS, Fast CDR and OpenSSL's libcrypto (DDS Security) are not built with TSan
      # (libcrypto's own locks and atomics then read as races), and libstdc++'s timed mutexes lock
      # through pthread_mutex_clocklock, which gcc 12's TSan does not intercept: reports
      # inside those libraries are noise (unlock of an unlocked mutex, races between DDS
      # threads). Reports with a storey frame on top still stop the run.
      printf '%s\n' 'called_from_lib:libfastrtps.so.2.9' 'mutex:libstdc++.so.6' \
        'mutex:libfastrtps.so.2.9' 'race:libfastrtps.so.2.9' 'race:libfastcdr.so.1' \
        'race:libfoonathan_memory' 'deadlock:libfastrtps.so.2.9' \
        'called_from_lib:libcrypto.so.3' 'race:libcrypto.so.3' >build-tsan/tsan.supp
      export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$PWD/build-tsan/tsan.supp"
      phase "tsan build" build build-tsan integration_runtime_tests runtime_test_node \
        integration_security_tests
      phase "tsan runtime integration tests" \
        build-tsan/tests/integration/runtime/integration_runtime_tests
      phase "tsan security integration tests" \
        build-tsan/tests/integration/security/integration_security_tests
      ;;
    *)
      echo "sanitize.sh: unknown mode '$mode' (asan or tsan)" >&2
      exit 2
      ;;
  esac
done
exit $status
