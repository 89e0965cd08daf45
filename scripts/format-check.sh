#!/usr/bin/env bash
# Checks that the C++ lines changed since a base commit are formatted as .clang-format
# says (git clang-format --diff: only changed lines, so untouched code is not reflowed).
# The base is packages.sh's check_base (STOREY_CHECK_BASE, the merge base with main, or on
# main the commit before HEAD). Prints the diff to apply
# (`git clang-format BASE` applies it) and exits 1 when a changed line is not formatted.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/packages.sh
ensure_packages clang-format
base=$(check_base)
if [ -z "$base" ]; then
  echo "format-check.sh: no main branch to compare with; skipped"
  exit 0
fi
# git clang-format 14 exits 0 either way: a diff in its output is the finding.
out=$(git clang-format --diff --extensions cpp,h,hpp,cc "$base" 2>&1)
if ! grep -q '^diff --git' <<<"$out"; then
  echo "format-check.sh: changed lines since ${base:0:12} are formatted"
else
  echo "$out"
  echo "format-check.sh: changed lines since ${base:0:12} are not formatted; run: git clang-format $base"
  exit 1
fi
