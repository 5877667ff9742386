#!/usr/bin/env bash
# Starts, stops or reports prismfarm workers on a list of hosts over ssh: one worker per host
# and master, run by `systemd-run --user` where the host has a user manager, else by nohup
# (pid and log under ~/.local/state/prismfarm/). Idempotent: starting a running worker or
# stopping a stopped one changes nothing and says so. --dry-run prints the ssh commands only.
set -euo pipefail

usage() {
  cat <<'EOF'
usage: deploy/start-workers.sh [options] start|stop|status [HOST...]

Runs `prismfarm worker --connect ENDPOINT` on each HOST over ssh (one worker per host and
master; a second `start` finds it running and leaves it), stops it, or says whether it runs.
`start` needs the keys (paths on the hosts: docs/security.md) or --insecure.

options:
  -m, --master M       the master: a host name or address (tcp://M:PORT), or a full worker
                       endpoint tcp://HOST:PORT; required, it also tells workers of two
                       masters apart on one host
  -f, --hosts FILE     more hosts, one per line: HOST [THREADS]; '#' starts a comment
  -t, --threads N      render threads per worker (default: every core of the host)
  -p, --port N         the master's worker port when --master is a host (default 5555)
  -k, --key FILE       the worker's key pair on each host (NAME.key from prismfarm keygen,
                       made on that host; its NAME.pub in the master's --authorized folder)
  -K, --master-key FILE
                       the master's public key (its NAME.pub) on each host
      --insecure       plain text instead of CURVE (a network you trust)
      --bin PATH       prismfarm on the hosts (default: prismfarm, found in PATH)
      --cache DIR      scene cache on the hosts (default: the worker's own)
      --launcher L     auto (systemd-run --user if the host has a user manager, else
                       nohup), systemd or nohup (default auto)
      --ssh CMD        the ssh command, split at spaces (default: $PRISMFARM_SSH or
                       "ssh -o BatchMode=yes -o ConnectTimeout=10")
  -j, --jobs N         hosts contacted at once (default 16)
  -n, --dry-run        print the ssh command for each host and do nothing
  -h, --help           this text

HOST is anything ssh takes (name, address, user@name); the worker is named after it.
Exit status: 0 all went well (status: all running), 1 a host failed or was unreachable,
2 bad arguments, 3 (status) some worker is not running.
EOF
}

die_usage() {
  echo "start-workers.sh: $*" >&2
  echo "(see deploy/start-workers.sh --help)" >&2
  exit 2
}

# The part that runs on each host, as POSIX sh (the hosts' /bin/sh may be dash or busybox).
# Arguments: ACTION ENDPOINT TAG THREADS BIN NAME CACHE LAUNCHER KEY MASTER_KEY INSECURE
# (empty = default; INSECURE is "insecure" or empty).
read -r -d '' REMOTE_SCRIPT <<'REMOTE' || true
# Everything sits in one function, parsed whole before it runs, with stdin from /dev/null:
# the script itself arrives on stdin, and no command may eat the rest of it.
remote_main() {
set -u
action=$1 ep=$2 tag=$3 threads=$4 bin=$5 name=$6 cache=$7 launcher=$8 key=$9
shift 9
master_key=$1 insecure=$2
unit=prismfarm-worker-$tag
state=${XDG_STATE_HOME:-$HOME/.local/state}/prismfarm
pidf=$state/worker-$tag.pid
log=$state/worker-$tag.log

# kill -0 also succeeds on a zombie, which an init that does not reap orphans leaves behind.
alive() {
  kill -0 "$1" 2>/dev/null || return 1
  if [ -r "/proc/$1/stat" ]; then
    [ "$(sed 's/.*) //' "/proc/$1/stat" | cut -c1)" != Z ]
  fi
}
user_systemd() {
  command -v systemd-run >/dev/null 2>&1 && systemctl --user show-environment >/dev/null 2>&1
}
# The pid in the pid file, if that process is still this master's worker (pids get reused).
nohup_pid() {
  [ -f "$pidf" ] || return 1
  p=$(cat "$pidf" 2>/dev/null) || return 1
  case "$p" in ''|*[!0-9]*) return 1 ;; esac
  alive "$p" || return 1
  if [ -r "/proc/$p/cmdline" ]; then
    args=$(tr '\0' ' ' <"/proc/$p/cmdline")
  else
    args="$(ps -p "$p" -o args= 2>/dev/null) "
  fi
  case "$args" in *" worker --connect $ep "*) echo "$p" ;; *) return 1 ;; esac
}
unit_active() {
  [ "$launcher" != nohup ] && user_systemd && systemctl --user is-active --quiet "$unit"
}

case "$launcher" in
  auto) if user_systemd; then launcher="systemd"; else launcher="nohup"; fi ;;
  systemd) user_systemd || { echo "no systemd user manager here (use --launcher nohup)"; exit 1; } ;;
  nohup) ;;
esac

case "$action" in
start)
  if unit_active; then echo "already running (systemd --user unit $unit)"; exit 0; fi
  if p=$(nohup_pid); then echo "already running (pid $p, log $log)"; exit 0; fi
  exe=$(command -v "$bin" 2>/dev/null) || { echo "'$bin' not found (install prismfarm there, or pass --bin)"; exit 1; }
  set -- worker --connect "$ep" --name "$name"
  if [ -n "$threads" ]; then set -- "$@" --threads "$threads"; fi
  if [ -n "$cache" ]; then set -- "$@" --cache "$cache"; fi
  if [ -n "$insecure" ]; then
    set -- "$@" --insecure
  else
    # The worker reads them as it starts: a missing file is reported now, not in its log.
    for f in "$key" "$master_key"; do
      [ -r "$f" ] || { echo "cannot read '$f' (make the keys on this host: docs/security.md)"; exit 1; }
    done
    set -- "$@" --key "$key" --master-key "$master_key"
  fi
  if [ "$launcher" = systemd ]; then
    systemctl --user reset-failed "$unit" >/dev/null 2>&1 || true
    systemd-run --user --quiet --collect --unit="$unit" -p Restart=on-failure -p RestartSec=5 \
      -p RestartPreventExitStatus=2 "$exe" "$@" || exit 1
    sleep 1
    if ! systemctl --user is-active --quiet "$unit"; then
      echo "the worker exited at once:"
      journalctl --user -u "$unit" -n 5 --no-pager 2>/dev/null
      exit 1
    fi
    echo "started (systemd --user unit $unit; logs: journalctl --user -u $unit)"
    exit 0
  fi
  mkdir -p "$state" || exit 1
  rm -f "$pidf"
  # The inner sh writes its own pid and execs the worker, so the pid file holds the worker's
  # pid even if setsid had to fork. setsid and nohup keep it alive after ssh hangs up.
  detach=
  if command -v setsid >/dev/null 2>&1; then detach=setsid; fi
  # shellcheck disable=SC2016 # $$ and $0 belong to the inner sh
  $detach nohup sh -c 'echo $$ >"$0"; exec "$@"' "$pidf" "$exe" "$@" >>"$log" 2>&1 </dev/null &
  i=0
  while [ ! -s "$pidf" ] && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
  sleep 0.5
  if ! p=$(nohup_pid); then
    echo "the worker exited at once; the end of $log:"
    tail -n 5 "$log"
    rm -f "$pidf"
    exit 1
  fi
  echo "started (pid $p, log $log)"
  ;;
stop)
  done_=
  if unit_active; then
    systemctl --user stop "$unit" || exit 1
    echo "stopped (systemd --user unit $unit)"
    done_=1
  fi
  if p=$(nohup_pid); then
    kill -TERM "$p" 2>/dev/null || true
    i=0
    while alive "$p" && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    how=SIGTERM
    if alive "$p"; then kill -KILL "$p" 2>/dev/null || true; how="SIGKILL after 10 s"; fi
    rm -f "$pidf"
    echo "stopped (pid $p, $how)"
    done_=1
  fi
  [ -n "$done_" ] || echo "not running"
  ;;
status)
  if unit_active; then echo "running (systemd --user unit $unit)"; exit 0; fi
  if p=$(nohup_pid); then echo "running (pid $p, log $log)"; exit 0; fi
  echo "not running"
  exit 3
  ;;
*)
  echo "unknown action '$action'"
  exit 2
  ;;
esac
}
remote_main "$@" </dev/null
REMOTE

# Quotes one word for the remote shell (ssh hands the joined command line to it).
q() {
  local s=${1//\'/\'\\\'\'}
  printf "'%s'" "$s"
}

action=
master=
hosts_file=
threads=
port=5555
bin=prismfarm
cache=
launcher=auto
ssh_cmd=${PRISMFARM_SSH:-ssh -o BatchMode=yes -o ConnectTimeout=10}
jobs=16
dry=0
key=
master_key=
insecure=
args=()

need() { [ "$2" -ge 2 ] || die_usage "$1 needs a value"; }
while [ $# -gt 0 ]; do
  case "$1" in
    -m|--master) need "$1" $#; master=$2; shift 2 ;;
    -f|--hosts) need "$1" $#; hosts_file=$2; shift 2 ;;
    -t|--threads) need "$1" $#; threads=$2; shift 2 ;;
    -p|--port) need "$1" $#; port=$2; shift 2 ;;
    -k|--key) need "$1" $#; key=$2; shift 2 ;;
    -K|--master-key) need "$1" $#; master_key=$2; shift 2 ;;
    --insecure) insecure=insecure; shift ;;
    --bin) need "$1" $#; bin=$2; shift 2 ;;
    --cache) need "$1" $#; cache=$2; shift 2 ;;
    --launcher) need "$1" $#; launcher=$2; shift 2 ;;
    --ssh) need "$1" $#; ssh_cmd=$2; shift 2 ;;
    -j|--jobs) need "$1" $#; jobs=$2; shift 2 ;;
    -n|--dry-run) dry=1; shift ;;
    -h|--help) usage; exit 0 ;;
    --) shift; args+=("$@"); break ;;
    -*) die_usage "unknown option '$1'" ;;
    *) args+=("$1"); shift ;;
  esac
done

[ ${#args[@]} -gt 0 ] || die_usage "expected an action: start, stop or status"
action=${args[0]}
case "$action" in
  start|stop|status) ;;
  *) die_usage "expected an action (start, stop or status), got '$action'" ;;
esac

is_count() { [[ "$1" =~ ^[1-9][0-9]*$ ]] && [ "${#1}" -le 5 ] && [ "$1" -le "$2" ]; }
[ -n "$master" ] || die_usage "--master is required (the host or endpoint workers connect to)"
[ -z "$threads" ] || is_count "$threads" 1024 || die_usage "--threads expects an integer in 1..1024, got '$threads'"
is_count "$port" 65535 || die_usage "--port expects an integer in 1..65535, got '$port'"
is_count "$jobs" 1024 || die_usage "--jobs expects an integer in 1..1024, got '$jobs'"
case "$launcher" in auto|systemd|nohup) ;; *) die_usage "--launcher expects auto, systemd or nohup, got '$launcher'" ;; esac
read -r -a ssh <<<"$ssh_cmd"
[ ${#ssh[@]} -gt 0 ] || die_usage "--ssh is empty"

case "$master" in
  *://*) endpoint=$master ;;
  *) endpoint=tcp://$master:$port ;;
esac
endpoint_re='^tcp://[][A-Za-z0-9._:-]+:[0-9]+$'
[[ "$endpoint" =~ $endpoint_re ]] || die_usage "--master '$master' does not give an endpoint tcp://HOST:PORT"
# One worker per host and master: the tag names its unit, pid file and log.
tag=${endpoint#tcp://}
tag=${tag//[^A-Za-z0-9.-]/-}

# Hosts from the file, then from the command line; each once, in order of first appearance.
host_list=()
host_threads=()
add_host() {
  local h=$1 t=$2 where=$3 k
  if [[ ! "$h" =~ ^[A-Za-z0-9._@:-]+$ ]] || [[ "$h" == -* ]]; then
    die_usage "$where: '$h' is not a host name"
  fi
  [ -z "$t" ] || is_count "$t" 1024 || die_usage "$where: threads for '$h' must be in 1..1024, got '$t'"
  for k in "${host_list[@]+"${host_list[@]}"}"; do
    [ "$k" != "$h" ] || return 0
  done
  host_list+=("$h")
  host_threads+=("$t")
}
if [ -n "$hosts_file" ]; then
  [ -r "$hosts_file" ] || die_usage "cannot read hosts file '$hosts_file'"
  n=0
  while IFS= read -r line || [ -n "$line" ]; do
    n=$((n + 1))
    line=${line%%#*}
    read -r -a words <<<"$line" || true
    [ ${#words[@]} -gt 0 ] || continue
    [ ${#words[@]} -le 2 ] || die_usage "$hosts_file:$n: expected HOST [THREADS], got '$line'"
    add_host "${words[0]}" "${words[1]:-}" "$hosts_file:$n"
  done <"$hosts_file"
fi
for h in "${args[@]:1}"; do
  add_host "$h" "" "argument"
done
[ ${#host_list[@]} -gt 0 ] || die_usage "no hosts: give them as arguments or with --hosts FILE"
if [ -n "$insecure" ]; then
  [ -z "$key$master_key" ] || die_usage "--insecure and --key/--master-key exclude each other"
elif [ "$action" = start ]; then
  [ -n "$key" ] && [ -n "$master_key" ] ||
    die_usage "start needs --key FILE and --master-key FILE (paths on the hosts; docs/security.md), or --insecure"
fi

remote_command() {
  local host=$1 t=$2
  printf 'sh -s -- %s %s %s %s %s %s %s %s %s %s %s' "$(q "$action")" "$(q "$endpoint")" \
    "$(q "$tag")" "$(q "$t")" "$(q "$bin")" "$(q "${host#*@}")" "$(q "$cache")" "$(q "$launcher")" \
    "$(q "$key")" "$(q "$master_key")" "$(q "$insecure")"
}

if [ "$dry" -eq 1 ]; then
  echo "# $action workers for $endpoint on ${#host_list[@]} host(s); each command reads the remote script on stdin"
  for i in "${!host_list[@]}"; do
    t=${host_threads[$i]:-$threads}
    echo "${ssh[*]} ${host_list[$i]} $(remote_command "${host_list[$i]}" "$t")"
  done
  exit 0
fi

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
running=0
for i in "${!host_list[@]}"; do
  h=${host_list[$i]}
  t=${host_threads[$i]:-$threads}
  (
    rc=0
    "${ssh[@]}" "$h" "$(remote_command "$h" "$t")" <<<"$REMOTE_SCRIPT" >"$out/$i" 2>&1 || rc=$?
    echo "$rc" >"$out/$i.rc"
  ) &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait

status=0
for i in "${!host_list[@]}"; do
  rc=$(cat "$out/$i.rc" 2>/dev/null || echo 1)
  if [ -s "$out/$i" ]; then
    sed "s|^|${host_list[$i]}: |" "$out/$i"
  else
    echo "${host_list[$i]}: no answer"
  fi
  case "$rc" in
    0) ;;
    3) [ "$status" -eq 1 ] || status=3 ;;
    255) echo "${host_list[$i]}: ssh failed (exit 255)"; status=1 ;;
    *) status=1 ;;
  esac
done
exit "$status"
