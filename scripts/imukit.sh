#!/usr/bin/env bash
# Builds the imukit command if needed (installing dependencies on a fresh machine) and runs it:
#   bash scripts/imukit.sh COMMAND [ARGS...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup.sh" >&2
if [ ! -f "$root/build/release/build.ninja" ]; then
  cmake -S "$root" -B "$root/build/release" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DIMUKIT_ASSERTIONS=ON >/dev/null
fi
cmake --build "$root/build/release" -j"${IMUKIT_JOBS:-2}" --target imukit >&2
exec "$root/build/release/cli/imukit" "$@"
