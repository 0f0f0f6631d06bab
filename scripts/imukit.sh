#!/usr/bin/env bash
# Builds the imukit command if needed (installing dependencies on a fresh machine) and runs it:
#   bash scripts/imukit.sh COMMAND [ARGS...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup.sh" >&2
# The configuration scripts/test.sh uses too (a no-op when it is already in place).
bash "$root/scripts/configure_release.sh"
cmake --build "$root/build/release" -j"${IMUKIT_JOBS:-2}" --target imukit >&2
exec "$root/build/release/cli/imukit" "$@"
