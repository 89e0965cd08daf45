#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy) on the C++ sources changed since packages.sh's check_base
# (the merge base with main; on main, the commit before HEAD), or on the files given, one
# file per core at a time. scripts/test.sh runs it after the format check. Exits 1 when a
# check reports in storey's own code.
# The build is a unity build, whose compile database names only the unity files: each
# source is checked with the command of the unity file that includes it.
# Usage: scripts/tidy.sh [file.cpp...]
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/packages.sh
ensure_packages clang-tidy
build_dir=${STOREY_BUILD_DIR:-build}
[ -f "$build_dir/compile_commands.json" ] || ./scripts/setup.sh
files=("$@")
if [ ${#files[@]} -eq 0 ]; then
  base=$(check_base)
  [ -n "$base" ] || { echo "tidy.sh: no base commit to compare with; skipped"; exit 0; }
  mapfile -t files < <(git diff --name-only --diff-filter=d "$base" -- '*.cpp' |
                       grep -v '^tests/fuzz/\|^tests/interop/' || true)
fi
[ ${#files[@]} -eq 0 ] && { echo "tidy.sh: no changed sources"; exit 0; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# One compile database per source, in its own folder: the including unity file's entry
# with that file's path replaced by the source's (or the source's own entry).
n=0
for f in "${files[@]}"; do
  abs=$PWD/$f
  unity=$(grep -rlF --include="*.cxx" "#include \"$abs\"" "$(realpath "$build_dir")" | head -1 || true)
  entry=$(grep -B2 -F "\"file\": \"${unity:-$abs}\"" "$build_dir/compile_commands.json" || true)
  if [ -z "$entry" ]; then
    echo "tidy.sh: $f: not in the build's compile database; skipped"
    continue
  fi
  n=$((n + 1))
  mkdir -p "$work/$n"
  [ -n "$unity" ] && entry=${entry//"$unity"/"$abs"}
  printf '[\n{\n%s\n}\n]\n' "$entry" >"$work/$n/compile_commands.json"
  echo "$n $f" >>"$work/list"
done
[ -f "$work/list" ] || exit 0
check() {
  local out
  out=$(clang-tidy -p "$work/$1" --quiet "$2" 2>/dev/null || true)
  if grep -q 'warning:\|error:' <<<"$out"; then
    echo "$out"
    echo "tidy.sh: $2: findings above"
    return 1
  fi
  echo "tidy.sh: $2: clean"
}
export -f check
export work
xargs -P "$(nproc)" -L 1 bash -c 'check "$0" "$1"' <"$work/list"
