#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy) on the C++ sources changed since the merge base with main
# (or STOREY_FORMAT_BASE), or on the files given, with the compile commands of
# ${STOREY_BUILD_DIR:-build}. Exits 1 when a check reports in storey's own code. Not part
# of scripts/test.sh: a file takes 10 s or more of CPU, and CI's time is spent on tests.
# Usage: scripts/tidy.sh [file.cpp...]
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/packages.sh
ensure_packages clang-tidy
build_dir=${STOREY_BUILD_DIR:-build}
[ -f "$build_dir/compile_commands.json" ] || ./scripts/setup.sh
files=("$@")
if [ ${#files[@]} -eq 0 ]; then
  base=${STOREY_FORMAT_BASE:-$(git merge-base HEAD main 2>/dev/null || git merge-base HEAD origin/main)}
  mapfile -t files < <(git diff --name-only --diff-filter=d "$base" -- '*.cpp' | grep -v '^tests/fuzz/' || true)
fi
[ ${#files[@]} -eq 0 ] && { echo "tidy.sh: no changed sources"; exit 0; }
status=0
for f in "${files[@]}"; do
  out=$(clang-tidy -p "$build_dir" --quiet "$f" 2>/dev/null || true)
  if grep -q 'warning:\|error:' <<<"$out"; then
    echo "$out"
    echo "tidy.sh: $f: findings above"
    status=1
  else
    echo "tidy.sh: $f: clean"
  fi
done
exit $status
