#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz) with clang, ASan and UBSan into build-asan (the
# sanitizer build scripts/sanitize.sh uses too; scripts/configure-asan.sh) and
# runs each for SECONDS (default 60), printing executions and coverage per target.
# Usage: scripts/fuzz.sh [SECONDS] [target...]   (targets: carmen graph scenario config bag
# journal journal_file cdr). New crashing inputs are left in build-asan/fuzz/findings/<target>/; keep each as
# a regression input under tests/fuzz/regressions/<target>/ (docs/fuzzing.md).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(carmen graph scenario config bag journal journal_file cdr)
scripts/configure-asan.sh

# One build at a time on the shared machine (the lock scripts/dev-build.sh takes).
exec 9>/tmp/storey-build.lock
flock 9
build_targets=()
for t in "${targets[@]}"; do build_targets+=(--target "fuzz_$t"); done
cmake --build build-asan --parallel "$(nproc)" "${build_targets[@]}"
flock -u 9

# Huge length fields must come back as bad_alloc (a clean error), not an ASan abort.
export ASAN_OPTIONS=allocator_may_return_null=1:detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
status=0
printf '%-10s %12s %10s %8s %8s  %s\n' target executions exec/s cov ft result
for t in "${targets[@]}"; do
  corpus=build-asan/fuzz/corpus/$t
  findings=build-asan/fuzz/findings/$t
  mkdir -p "$corpus" "$findings"
  seeds=()
  [ -d tests/fuzz/corpus/$t ] && seeds+=(tests/fuzz/corpus/$t)
  [ -d tests/fuzz/regressions/$t ] && seeds+=(tests/fuzz/regressions/$t)
  log=build-asan/fuzz/fuzz_$t.log
  # One process; -seed fixed so a run is repeatable for the same corpus.
  if build-asan/tests/fuzz/fuzz_$t -max_total_time="$seconds" -seed=1 -rss_limit_mb=2048 \
      -max_len=65536 -timeout=10 -artifact_prefix="$findings/" -print_final_stats=1 \
      "$corpus" "${seeds[@]}" >"$log" 2>&1; then
    result=ok
  else
    result="CRASH (see $log, input in $findings/)"
    status=1
  fi
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || true)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || true)
  printf '%-10s %12s %10s %8s %8s  %s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "$result"
done
exit $status
