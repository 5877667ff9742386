#!/usr/bin/env bash
# Checks the shipped systemd units, deploy/systemd/*.service, with systemd's own parser: stages
# them with `deploy/install.sh --destdir` (as a host would get them, ExecStart naming the
# installed binary, which is the built one copied there), then runs
#   systemd-analyze verify --root=STAGE   on the master and two worker instances (a host name
#                                          and a number): it must exit 0 and print nothing;
#   systemd-analyze security --offline=yes --threshold=20 --root=STAGE   on the same three:
#                                          each unit's exposure must be 2.0 or less ("OK").
# The check is first shown able to fail: a copy with a misspelt directive must make verify print.
# Units are parsed, not started: this needs no systemd running as PID 1.
#
# Exit 0: passed; 1: failed (with systemd-analyze's words); 77: skipped, only when
# systemd-analyze is not installed (Debian: the systemd package) or the machine has no
# /usr/lib/systemd/system to give the staged root its targets.
#
# Environment: PRISMFARM_BIN (the prismfarm executable), PRISMFARM_SOURCE_DIR (the repository).
set -uo pipefail

me=test_systemd_units
src=${PRISMFARM_SOURCE_DIR:-$(cd "$(dirname "$0")/../.." && pwd)}
bin=${PRISMFARM_BIN:-$src/build/cli/prismfarm}
[ -x "$bin" ] || { echo "$me: FAILED: no prismfarm executable at '$bin' (set PRISMFARM_BIN)" >&2; exit 1; }
command -v systemd-analyze >/dev/null 2>&1 ||
  { echo "$me: SKIPPED: systemd-analyze is not installed (Debian: apt-get install systemd)"; exit 77; }
sysunits=/usr/lib/systemd/system
[ -d "$sysunits" ] || sysunits=/lib/systemd/system
[ -f "$sysunits/sysinit.target" ] ||
  { echo "$me: SKIPPED: no $sysunits/sysinit.target to copy into the staged root"; exit 77; }

stage=$(mktemp -d "${TMPDIR:-/tmp}/pf-units-XXXXXX") || exit 1
trap 'rm -rf "$stage"' EXIT
fail() { echo "$me: FAILED: $*" >&2; exit 1; }

bash "$src/deploy/install.sh" --destdir "$stage/root" --binary "$bin" >"$stage/install.out" 2>&1 ||
  fail "install.sh --destdir: $(cat "$stage/install.out")"
# verify --root resolves the units' dependencies (sysinit.target, network-online.target, ...) and
# the worker's /bin/sh inside the root: give it the machine's own.
mkdir -p "$stage/root/usr/lib/systemd" "$stage/root/bin"
cp -a "$sysunits" "$stage/root/usr/lib/systemd/system"
cp /bin/sh "$stage/root/bin/sh"
units=(/etc/systemd/system/prismfarm-master.service /etc/systemd/system/prismfarm-worker@render1.service
       /etc/systemd/system/prismfarm-worker@2.service)
grep -q '^ExecStart=/usr/local/bin/prismfarm master' "$stage/root${units[0]}" ||
  fail "the staged master unit does not start /usr/local/bin/prismfarm"
[ -x "$stage/root/usr/local/bin/prismfarm" ] || fail "install.sh staged no executable /usr/local/bin/prismfarm"

# The check can fail: a misspelt directive in a copy is reported (verify exits 0 on it, so the
# output is what counts).
mkdir -p "$stage/bad/etc/systemd/system" "$stage/bad/usr/lib/systemd" "$stage/bad/bin" "$stage/bad/usr/local/bin"
cp -a "$stage/root/usr/lib/systemd/system" "$stage/bad/usr/lib/systemd/"
cp "$stage/root/bin/sh" "$stage/bad/bin/sh"
cp "$stage/root/usr/local/bin/prismfarm" "$stage/bad/usr/local/bin/prismfarm"
sed 's/^NoNewPrivileges=/NoNewPrivilegs=/' "$stage/root${units[0]}" >"$stage/bad${units[0]}"
out=$(systemd-analyze verify --root="$stage/bad" "${units[0]}" 2>&1)
grep -q NoNewPrivilegs <<<"$out" || fail "verify did not report a misspelt directive (it printed: '$out')"

for u in "${units[@]}"; do
  out=$(systemd-analyze verify --root="$stage/root" "$u" 2>&1)
  rc=$?
  if [ "$rc" -ne 0 ] || [ -n "$out" ]; then fail "systemd-analyze verify $u: exit $rc: $out"; fi
  out=$(systemd-analyze security --offline=yes --threshold=20 --root="$stage/root" "$u" 2>&1)
  rc=$?
  [ "$rc" -eq 0 ] || fail "systemd-analyze security $u: exit $rc (exposure above 2.0): $(tail -n 3 <<<"$out")"
  echo "$me: $(basename "$u"): verify silent; $(grep -o 'Overall exposure level.*' <<<"$out")"
done
echo "$me: passed ($(systemd-analyze --version | head -n 1))"
