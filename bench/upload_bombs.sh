#!/usr/bin/env bash
# The adversarial uploads of issue 26, finding 2, sent straight to a master process as SUBMIT
# messages (tests/farm/test_upload_budgets.c makes them and measures): a 1.2 MB .ply.gz whose
# header claims 10^8 vertices, a 4.3 MB gzip bomb of 4 GiB of spaces, a 4 MB file Included 400
# times beside a second client's small scene. Prints, for each, the seconds from SUBMIT to the
# master's answer, the master's peak resident memory (VmHWM) and the answer, with this tree's
# prismfarm ("after") and, with --before BIN, another one ("before": e.g. 40e09f1's, built in a
# worktree, `cmake --build B --target prismfarm`). The masters run under an address-space cap
# of AS_MB MiB (default 4096) so that a master without the budgets fails for lack of memory
# instead of taking the machine's (unset it with AS_MB=0 on a machine with 12 GB to spare).
# The test's own checks fail for a "before" master; only its figures matter here.
#   bash bench/upload_bombs.sh [--before BIN]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
BEFORE=
[[ ${1:-} == --before ]] && BEFORE=$(realpath "$2")
nice cmake --build "$BUILD" --target prismfarm test_upload_budgets >/dev/null
TEST=$(realpath "$BUILD/tests/test_upload_budgets")
run() { # label prismfarm
  (cd tests && PRISMFARM_BIN=$2 PRISMFARM_TEST_WAIT_S=900 PRISMFARM_BOMB_AS_MB=${AS_MB:-4096} \
     "$TEST" 2>&1 || true) |
    grep -E "^\[ RUN|answered" | sed -e "s/^\[ RUN      \] /$1 /" -e "s/^/  /"
}
echo "after ($BUILD/cli/prismfarm):"
run after "$(realpath "$BUILD/cli/prismfarm")"
if [[ -n $BEFORE ]]; then
  echo "before ($BEFORE):"
  run before "$BEFORE"
fi
