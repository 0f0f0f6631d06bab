#!/usr/bin/env bash
# The one configuration of build/release, shared by scripts/imukit.sh (the README's demo command)
# and scripts/test.sh (CI): with the same flags neither rebuilds what the other built.
#   bash scripts/configure_release.sh [EXTRA CMAKE ARGS...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cmake -S "$root" -B "$root/build/release" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DIMUKIT_ASSERTIONS=ON -DIMUKIT_WERROR=ON "$@" >/dev/null
