#!/usr/bin/env bash
# Pretend hosts on one machine for tests/farm/test_farm_netns.c: each "host" is a network namespace
# PREFIX-NAME whose eth0 (one end of a veth pair) is plugged into a bridge in a switch namespace
# PREFIX-sw. Nothing is added to the caller's namespace, so concurrent runs with different
# prefixes cannot collide even with the same addresses. Needs root and iproute2.
#
#   netns-hosts.sh check PREFIX                 exit 0 if namespaces can be created here
#   netns-hosts.sh up PREFIX NAME=ADDR/LEN...   create the switch and the hosts
#   netns-hosts.sh down PREFIX                  kill what runs in PREFIX-* and delete them
#   netns-hosts.sh reap BASE                    `down` every BASE-<pid>-* whose pid is gone
#   netns-hosts.sh ssh NS COMMAND...            run COMMAND in NS as ssh runs it on a host:
#                                               joined by spaces, through sh -c, with HOME set
#                                               to $NETNS_HOSTS_HOME/NS when that is set
set -euo pipefail

die() { echo "netns-hosts.sh: $*" >&2; exit 1; }

# The namespaces whose names start with "$1-".
list() {
  ip netns list | awk -v p="$1-" 'index($1, p) == 1 { print $1 }'
}

down() {
  local ns pid
  for ns in $(list "$1"); do
    # A namespace outlives `ip netns del` while a process runs in it: end those first.
    for pid in $(ip netns pids "$ns" 2>/dev/null); do
      kill -KILL "$pid" 2>/dev/null || true
    done
  done
  for ns in $(list "$1"); do
    ip netns del "$ns" 2>/dev/null || true
  done
  [ -z "$(list "$1")" ] || die "could not delete: $(list "$1" | tr '\n' ' ')"
}

[ $# -ge 2 ] || die "usage: check|up|down|reap PREFIX ... or ssh NS COMMAND..."
cmd=$1
prefix=$2
shift 2
case "$cmd" in
check)
  command -v ip >/dev/null || die "'ip' not found (Debian package iproute2)"
  ip netns add "$prefix-probe" || die "cannot create a network namespace (not root, or not allowed here)"
  ip -n "$prefix-probe" link add probe0 type bridge || { ip netns del "$prefix-probe"; die "cannot create a bridge in a namespace"; }
  ip netns del "$prefix-probe"
  ;;
up)
  [ $# -ge 1 ] || die "up: expected NAME=ADDR/LEN for each host"
  sw=$prefix-sw
  ip netns add "$sw"
  ip -n "$sw" link add br0 type bridge
  ip -n "$sw" link set br0 up
  for spec in "$@"; do
    name=${spec%%=*}
    addr=${spec#*=}
    [[ "$name" =~ ^[a-z0-9]{1,8}$ ]] || die "up: host name '$name' must be 1-8 of [a-z0-9]"
    ns=$prefix-$name
    ip netns add "$ns"
    ip -n "$ns" link set lo up
    # Created in the switch with its peer already inside the host: never in our namespace.
    ip -n "$sw" link add "v-$name" type veth peer name eth0 netns "$ns"
    ip -n "$sw" link set "v-$name" master br0
    ip -n "$sw" link set "v-$name" up
    ip -n "$ns" addr add "$addr" dev eth0
    ip -n "$ns" link set eth0 up
  done
  ;;
down)
  down "$prefix"
  ;;
reap)
  for ns in $(list "$prefix"); do
    rest=${ns#"$prefix"-}
    pid=${rest%%-*}
    [[ "$pid" =~ ^[0-9]+$ ]] || continue
    if ! kill -0 "$pid" 2>/dev/null; then
      down "$prefix-$pid"
    fi
  done
  ;;
ssh)
  ns=$prefix
  [ $# -ge 1 ] || die "ssh: expected a command"
  if [ -n "${NETNS_HOSTS_HOME:-}" ]; then
    mkdir -p "$NETNS_HOSTS_HOME/$ns"
    export HOME=$NETNS_HOSTS_HOME/$ns
  fi
  exec ip netns exec "$ns" sh -c "$*"
  ;;
*)
  die "unknown command '$cmd'"
  ;;
esac
