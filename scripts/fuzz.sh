#!/usr/bin/env bash
# Runs every libFuzzer target of a fuzz build for SECONDS each (default 600: the full run),
# IMUKIT_JOBS of them at a time (default 2: each fuzzer uses one core).
#   scripts/fuzz.sh [SECONDS] [BUILD_DIR]
# The seed corpus in fuzz/corpus/ is copied, never written to; findings land in BUILD_DIR/fuzz-findings.
set -euo pipefail
seconds=${1:-600}
build=${2:-build/asan}
jobs=${IMUKIT_JOBS:-2}
list="$build/fuzzers.txt"
if [ ! -s "$list" ]; then
  echo "fuzz: $list is missing: configure $build with -DIMUKIT_BUILD_FUZZERS=ON first" >&2
  exit 1
fi
findings="$build/fuzz-findings"
mkdir -p "$findings"

# One fuzzer on a copy of its seed corpus; one report when it ends (runs overlap, so nothing is
# printed at the start).
fuzz_one() {
  local name=$1 corpus=$2 work status=0
  work=$(mktemp -d)
  if [ -n "$corpus" ] && [ -d "$corpus" ]; then cp -r "$corpus"/. "$work"/; fi
  if ! "$build/fuzz/$name" -max_total_time="$seconds" -print_final_stats=0 \
        -artifact_prefix="$findings/$name-" "$work" >"$findings/$name.log" 2>&1; then
    { echo "fuzz: $name FAILED after up to ${seconds}s; last lines of $findings/$name.log:"
      tail -n 40 "$findings/$name.log"; } >&2
    status=1
  else
    echo "fuzz: $name ${seconds}s: $(grep -E "^(#[0-9]+.*DONE|Done)" "$findings/$name.log" | tail -n 1)"
  fi
  rm -rf "$work"
  return $status
}

status=0 running=0
while IFS='|' read -r name corpus; do
  [ -n "$name" ] || continue
  fuzz_one "$name" "$corpus" </dev/null &  # not the list: the loop reads it
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n || status=1
    running=$((running - 1))
  fi
done < "$list"
while [ "$running" -gt 0 ]; do
  wait -n || status=1
  running=$((running - 1))
done
exit $status
