#!/usr/bin/env bash
# Runs every libFuzzer target of a fuzz build for SECONDS each (default 600: the full run).
#   scripts/fuzz.sh [SECONDS] [BUILD_DIR]
# The seed corpus in fuzz/corpus/ is copied, never written to; findings land in BUILD_DIR/fuzz-findings.
set -euo pipefail
seconds=${1:-600}
build=${2:-build/asan}
root=$(cd "$(dirname "$0")/.." && pwd)
list="$build/fuzzers.txt"
if [ ! -s "$list" ]; then
  echo "fuzz: $list is missing: configure $build with -DIMUKIT_BUILD_FUZZERS=ON first" >&2
  exit 1
fi
findings="$build/fuzz-findings"
mkdir -p "$findings"
status=0
while IFS='|' read -r name corpus; do
  [ -n "$name" ] || continue
  work=$(mktemp -d)
  if [ -n "$corpus" ] && [ -d "$corpus" ]; then cp -r "$corpus"/. "$work"/; fi
  echo "fuzz: $name for ${seconds}s"
  if ! "$build/fuzz/$name" -max_total_time="$seconds" -print_final_stats=0 \
        -artifact_prefix="$findings/$name-" "$work" >"$findings/$name.log" 2>&1; then
    echo "fuzz: $name FAILED; last lines of $findings/$name.log:" >&2
    tail -n 40 "$findings/$name.log" >&2
    status=1
  else
    grep -E "^(#[0-9]+.*DONE|Done)" "$findings/$name.log" | tail -n 1 || true
  fi
  rm -rf "$work"
done < "$list"
exit $status
