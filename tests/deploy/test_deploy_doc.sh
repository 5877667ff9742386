#!/usr/bin/env bash
# docs/deploy.md says who listens on which port and which commands connect where: its tables must
# name every command `prismfarm --help` lists (a command added without a word on its network use
# fails here) and every option by which the master listens (--workers, --clients, --http, and
# /metrics on the dashboard). Reads the doc and the binary's help; starts nothing.
#
# Exit 0: passed; 1: failed, naming what the doc leaves out.
# Environment: PRISMFARM_BIN (the prismfarm executable), PRISMFARM_SOURCE_DIR (the repository).
set -uo pipefail
me=test_deploy_doc
src=${PRISMFARM_SOURCE_DIR:-$(cd "$(dirname "$0")/../.." && pwd)}
bin=${PRISMFARM_BIN:-$src/build/cli/prismfarm}
doc=$src/docs/deploy.md
[ -x "$bin" ] || { echo "$me: FAILED: no prismfarm executable at '$bin' (set PRISMFARM_BIN)" >&2; exit 1; }
[ -r "$doc" ] || { echo "$me: FAILED: cannot read $doc" >&2; exit 1; }

# The commands: the indented first words of the help's "commands:" list.
commands=$("$bin" --help 2>&1 | awk '/^commands:/ {on = 1; next} on && /^  [a-z]/ {print $1} on && /^$/ {on = 0}')
[ -n "$commands" ] || { echo "$me: FAILED: no command list in prismfarm --help" >&2; exit 1; }
# The section on ports and the lines above it (the table of what is deployed).
ports=$(awk '/^## The spool/ {exit} {print}' "$doc")
missing=()
for c in $commands; do
  grep -qE -- "\`$c\`|prismfarm $c\b" <<<"$ports" || missing+=("command '$c'")
done
for o in "--workers" "--clients" "--http" "/metrics" "5555" "5556"; do
  grep -q -- "$o" <<<"$ports" || missing+=("'$o'")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "$me: FAILED: docs/deploy.md's ports section does not name: ${missing[*]}" >&2
  exit 1
fi
echo "$me: passed: $(wc -w <<<"$commands") commands and the master's listening options named"
