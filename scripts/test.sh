#!/usr/bin/env bash
# The test command of the README: installs dependencies, builds and runs every test twice
# (gcc Release with assertions; clang with ASan+UBSan, also running each fuzzer briefly),
# and checks the firmware cross-build. Exits non-zero on any failure.
#   IMUKIT_FUZZ_SECONDS   seconds per fuzzer (default 10; scripts/fuzz.sh runs the full 600)
#   IMUKIT_SKIP_ASAN=1    skip the sanitizer pass (a quicker local run; CI never sets it)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
jobs=${IMUKIT_JOBS:-2}
fuzz_seconds=${IMUKIT_FUZZ_SECONDS:-10}
start=$(date +%s)
stamp() { echo "== [$(( $(date +%s) - start ))s] $*"; }

# The real recordings (tests/support/test_data.hpp): said once here, since without them the tests
# that read them are skipped (failed when CI=true), which is easy to miss in ctest's output.
data_dir=${IMUKIT_DATA_DIR:-$root/../shared/data}
if [ -d "$data_dir" ]; then
  stamp "test data: $(cd "$data_dir" && pwd)"
else
  stamp "test data: none at $data_dir: the tests on real recordings will be skipped (set IMUKIT_DATA_DIR)"
fi

stamp "setup"
bash scripts/setup.sh

stamp "release build (gcc, assertions on, -Werror)"
bash scripts/configure_release.sh  # the one scripts/imukit.sh uses: the demo's build is reused
cmake --build build/release -j"$jobs"
stamp "format check (clang-format, .clang-format)"
cmake --build build/release --target format-check
stamp "release tests"
(cd build/release && ctest --output-on-failure -j"$jobs" --timeout 900)

if [ -f scripts/check_firmware_size.sh ]; then
  stamp "firmware_proto cross-build for Cortex-M4"
  bash scripts/check_firmware_size.sh
fi

if [ "${IMUKIT_SKIP_ASAN:-0}" != 1 ]; then
  stamp "sanitizer build (clang, ASan+UBSan, fuzzers)"
  # -O1 with line tables: sanitizer reports keep file:line, and the build is much faster than -O2 -g.
  # A unity build (each target's files compiled together, so the shared headers are parsed and
  # their templates instantiated once per batch) takes about 40 % less CPU than one file at a
  # time (docs/benchmarks.md). The release build above compiles the libraries' files one at a
  # time, so a library file that leans on another's includes is caught there; the programs (tests,
  # CLI, Python module) are unity builds in both passes (IMUKIT_UNITY_PROGRAMS).
  CC=clang CXX=clang++ cmake -S . -B build/asan -G Ninja -DCMAKE_BUILD_TYPE=None \
    -DCMAKE_C_FLAGS="-O1 -gline-tables-only" -DCMAKE_CXX_FLAGS="-O1 -gline-tables-only" \
    -DCMAKE_UNITY_BUILD=ON \
    -DIMUKIT_SANITIZE=address,undefined -DIMUKIT_BUILD_FUZZERS=ON -DIMUKIT_BUILD_BENCHMARKS=OFF \
    -DIMUKIT_WERROR=ON >/dev/null
  cmake --build build/asan -j"$jobs"
  stamp "sanitizer tests"
  (cd build/asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
     UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     ctest --output-on-failure -j"$jobs" --timeout 1800 -LE no_sanitizer)
  stamp "fuzzers, ${fuzz_seconds}s each, $jobs at a time"
  IMUKIT_JOBS="$jobs" bash scripts/fuzz.sh "$fuzz_seconds" build/asan
fi
stamp "all passed"
