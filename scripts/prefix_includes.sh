#!/bin/sh
# Rewrites the project's include lines to the installed layout (docs/architecture.md, "Headers"):
# a module header "core/x.hpp" becomes "imukit/core/x.hpp"; the helpers of cli, python, fuzz,
# bench and tests are included from their own folder ("command.hpp", "support/test_data.hpp").
# Idempotent: run it on a branch made before the layout changed, then build.
#   sh scripts/prefix_includes.sh
set -eu
cd "$(git rev-parse --show-toplevel)"
modules='core|drivers|capture|hwmodel|sim|augment|firmware_proto'
git ls-files -z -- '*.cpp' '*.hpp' '*.h' '*.md' 'scripts/check_firmware_size.sh' |
  xargs -0 sed -i -E \
    -e "s@^([[:space:]]*#[[:space:]]*include[[:space:]]+)\"($modules)/([A-Za-z0-9_]+\.hpp)\"@\1\"imukit/\2/\3\"@" \
    -e "s@^([[:space:]]*#[[:space:]]*include[[:space:]]+)\"tests/support/@\1\"support/@" \
    -e "s@^([[:space:]]*#[[:space:]]*include[[:space:]]+)\"tests/drivers/@\1\"@" \
    -e "s@^([[:space:]]*#[[:space:]]*include[[:space:]]+)\"(cli|fuzz|bench|python/src)/@\1\"@"
# Anything left in the old form is an error.
if git grep -nE "#[[:space:]]*include[[:space:]]+\"(($modules)|tests|cli|fuzz|bench|python)/" -- \
     '*.cpp' '*.hpp' '*.h'; then
  echo "prefix_includes: the lines above still use the old form" >&2
  exit 1
fi
