#!/bin/sh
# Lists every function of the library modules and the command (lambdas included: ctags calls
# them __anon*) longer than N lines, longest first. The house rule is none over ~150 lines
# (docs/architecture.md); a function near it is split along its phases.
# Needs universal-ctags (apt-get install universal-ctags).
#   sh scripts/long_functions.sh [N]     (N = 150 by default; prints nothing when all are shorter)
set -eu
cd "$(git rev-parse --show-toplevel)"
N=${1:-150}
ctags -R --languages=C++ --c++-kinds=f --fields=+ne --output-format=u-ctags -f - \
      core drivers capture hwmodel sim augment cli firmware_proto |
  awk -F'\t' -v N="$N" '{
    start = ""; end = ""
    for (i = 4; i <= NF; i++) {
      if ($i ~ /^line:/) start = substr($i, 6)
      if ($i ~ /^end:/) end = substr($i, 5)
    }
    if (start != "" && end != "" && end - start + 1 > N)
      printf "%5d  %s:%d-%d  %s\n", end - start + 1, $2, start, end, $1
  }' | sort -rn
