#!/usr/bin/env bash
# Runs the shipped batch script, deploy/slurm/prismfarm.sbatch, under a real Slurm: Debian's
# slurmctld and slurmd on this one machine, with their own munged for authentication, all three
# started here from a configuration generated for the machine in a scratch folder (the system's
# /etc/slurm and /etc/munge are neither read nor changed), and stopped at the end, on failure too.
# Slurm gets three nodes, all this machine (three slurmd under different names and ports), and
# two jobs render data/render/tiny.pbrt through the script: one on its default three nodes (the
# master on the first, workers on the other two by the script's srun step), one on one node.
# Each passes when Slurm reports the job COMPLETED with exit code 0:0, NAME.exr and NAME.png are
# in the submit folder, the job's log says it wrote them and shows the workers it should, and
# nothing of the job is left in TMPDIR (the spool, the workers' keys and caches).
#
# Exit 0: passed; 1: failed (with what, and the daemons' logs); 77: skipped, only when Slurm
# cannot start here: not root (slurmd launches jobs as their user), or slurmctld, slurmd, the
# client commands or munged missing (deploy/install-deps.sh --test installs them). Every wait
# has a generous deadline and nothing is timed.
#
# Environment: PRISMFARM_BIN (the prismfarm executable), PRISMFARM_SOURCE_DIR (the repository);
# PRISMFARM_REQUIRE_SLURM=1 makes a skip a failure (CI sets it: there it must run);
# PRISMFARM_KEEP_SCRATCH=1 keeps the scratch folder for a look afterwards.
set -uo pipefail

me=test_slurm
skip() {
  if [ "${PRISMFARM_REQUIRE_SLURM:-0}" = 1 ]; then
    echo "$me: FAILED: cannot run, and PRISMFARM_REQUIRE_SLURM=1: $*" >&2
    exit 1
  fi
  echo "$me: SKIPPED: $*"
  exit 77
}
fail() {
  echo "$me: FAILED: $*" >&2
  dump_logs
  exit 1
}

src=${PRISMFARM_SOURCE_DIR:-$(cd "$(dirname "$0")/../.." && pwd)}
bin=${PRISMFARM_BIN:-$src/build/cli/prismfarm}
[ -x "$bin" ] || { echo "$me: FAILED: no prismfarm executable at '$bin' (set PRISMFARM_BIN)" >&2; exit 1; }
bin=$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")
script=$src/deploy/slurm/prismfarm.sbatch
scene=$src/tests/data/render/tiny.pbrt

[ "$(id -u)" -eq 0 ] || skip "not root: slurmd must run as root to start jobs (CI runs this as root)"
for c in slurmctld slurmd sbatch scontrol sinfo munged python3; do
  command -v "$c" >/dev/null 2>&1 ||
    skip "'$c' is not installed (Debian 12: apt-get install slurmctld slurmd slurm-client" \
      "munge, as deploy/install-deps.sh --test does)"
done

scratch=$(mktemp -d "${TMPDIR:-/tmp}/pf-slurm-XXXXXX") || { echo "$me: FAILED: mktemp" >&2; exit 1; }
chmod 755 "$scratch"
pids=()   # munged, slurmctld, slurmd: stopped in this order's reverse
job=

dump_logs() {
  local f
  for f in "$scratch"/munge/munged.log "$scratch"/slurmctld.log "$scratch"/slurmd-*.log \
           "$scratch"/*/prismfarm-*.log; do
    [ -s "$f" ] || continue
    echo "---- $f (last 40 lines)" >&2
    tail -n 40 "$f" >&2
  done
}

stop_all() {
  local i p
  if [ -n "$job" ] && [ -n "${SLURM_CONF:-}" ]; then scancel "$job" 2>/dev/null || true; fi
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    p=${pids[i]}
    kill -TERM "$p" 2>/dev/null || continue
    # A daemon that ignores SIGTERM for 30 s is killed.
    for _ in $(seq 300); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$p" 2>/dev/null || true
    wait "$p" 2>/dev/null || true
  done
  if [ "${PRISMFARM_KEEP_SCRATCH:-0}" = 1 ]; then
    echo "$me: scratch kept in $scratch"
  else
    rm -rf "$scratch"
  fi
}
trap stop_all EXIT
trap 'exit 143' TERM INT

# wait_for SECONDS WHAT COMMAND...: runs COMMAND every 0.2 s until it succeeds; fails after the
# deadline, naming WHAT.
wait_for() {
  local limit=$1 what=$2
  local deadline=$((SECONDS + limit))
  shift 2
  until "$@"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "no $what within $limit s"
    sleep 0.2
  done
}

# ---- munge: a key of our own, a socket of our own (the system's munged, if any, is left alone)
mkdir -m 755 "$scratch/munge"
head -c 1024 /dev/urandom >"$scratch/munge/munge.key"
chmod 400 "$scratch/munge/munge.key"
munge_socket=$scratch/munge/munge.socket
munged --foreground --force --key-file="$scratch/munge/munge.key" --socket="$munge_socket" \
  --pid-file="$scratch/munge/munged.pid" --log-file="$scratch/munge/munged.log" \
  --seed-file="$scratch/munge/munged.seed" >"$scratch/munge/munged.out" 2>&1 &
pids+=($!)
wait_for 30 "munge socket" test -S "$munge_socket"

# ---- slurm.conf for this machine: its real CPUs and memory, as slurmd -C reports them
host=$(hostname -s)
hw=$(slurmd -C 2>/dev/null | head -n 1)
cpus=$(sed -n 's/.* CPUs=\([0-9]*\).*/\1/p' <<<"$hw")
mem=$(sed -n 's/.* RealMemory=\([0-9]*\).*/\1/p' <<<"$hw")
[ -n "$cpus" ] || cpus=$(nproc)
[ -n "$mem" ] || mem=$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo)
# Four TCP ports free now, slurmctld's and one per slurmd (the system's Slurm, if any, keeps
# 6817/6818).
read -r ctld_port port1 port2 port3 < <(python3 -c '
import socket
s = [socket.socket() for _ in range(4)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
# Three nodes, all this machine (NodeAddr 127.0.0.1): three slurmd started with -N under
# different names on different ports, so that the script's srun step across "the other nodes"
# runs for real. Two of the names resolve nowhere: the script must reach the master's node by
# its NodeAddr, as Slurm does.
nodes=("$host" pfnode2 pfnode3)
ports=("$port1" "$port2" "$port3")
for n in "${nodes[@]}"; do mkdir -p "$scratch/spool/$n"; done
mkdir -p "$scratch/state" "$scratch/tmp"
export SLURM_CONF=$scratch/slurm.conf
cat >"$SLURM_CONF" <<EOF
# Generated by tests/deploy/test_slurm.sh: one node, this machine, everything under $scratch.
ClusterName=pftest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$munge_socket
StateSaveLocation=$scratch/state
SlurmdSpoolDir=$scratch/spool/%n
SlurmctldPidFile=$scratch/slurmctld.pid
SlurmdPidFile=$scratch/slurmd-%n.pid
SlurmctldLogFile=$scratch/slurmctld.log
SlurmdLogFile=$scratch/slurmd-%n.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroup delegation is assumed: processes are tracked by /proc, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=600
NodeName=${nodes[0]} NodeAddr=127.0.0.1 Port=${ports[0]} CPUs=$cpus RealMemory=$mem State=UNKNOWN
NodeName=${nodes[1]} NodeAddr=127.0.0.1 Port=${ports[1]} CPUs=$cpus RealMemory=$mem State=UNKNOWN
NodeName=${nodes[2]} NodeAddr=127.0.0.1 Port=${ports[2]} CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

t0=$SECONDS
slurmctld -D -c -f "$SLURM_CONF" >"$scratch/slurmctld.out" 2>&1 &
pids+=($!)
for n in "${nodes[@]}"; do
  slurmd -D -N "$n" -f "$SLURM_CONF" >"$scratch/slurmd-$n.out" 2>&1 &
  pids+=($!)
done
nodes_idle() {
  local i
  for i in "${pids[@]}"; do kill -0 "$i" 2>/dev/null || fail "a daemon exited (pid $i): $(cat "$scratch"/*.out)"; done
  [ "$(sinfo -h -N -o %T 2>/dev/null | grep -c '^idle$')" -eq 3 ]
}
wait_for 120 "three idle nodes in sinfo" nodes_idle
echo "$me: slurmctld and 3 slurmd up, nodes ${nodes[*]} idle ($cpus CPUs, $mem MB each) after $((SECONDS - t0)) s"

# ---- the jobs: the shipped script as a user submits it. run_job NAME SBATCH-OPTIONS... submits
# from the folder $scratch/NAME and checks what the script promises; sets $job and $log.
state=
exitcode=
job_over() {
  local line
  line=$(scontrol -o show job "$job" 2>/dev/null) || return 1
  state=$(sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' <<<"$line")
  exitcode=$(sed -n 's/.* ExitCode=\([0-9:]*\).*/\1/p' <<<"$line")
  case "$state" in PENDING | CONFIGURING | RUNNING | COMPLETING | "") return 1 ;; esac
}
run_job() {
  local dir=$scratch/$1 t=$SECONDS f leftover
  shift
  mkdir -p "$dir"
  job=$(cd "$dir" && PRISMFARM=$bin TMPDIR=$scratch/tmp sbatch --parsable "$@" "$script" "$scene" --spp 8) ||
    fail "sbatch refused the script: $job"
  job=${job%%;*}
  wait_for 300 "end of job $job" job_over
  echo "$me: job $job (sbatch $*) $state, exit code $exitcode, after $((SECONDS - t)) s"
  log=$dir/prismfarm-$job.log
  if [ "$state" != COMPLETED ] || [ "$exitcode" != 0:0 ]; then fail "job $job ended $state, exit code $exitcode"; fi
  for f in tiny.exr tiny.png; do
    [ -s "$dir/$f" ] || fail "job $job: no $f in the submit folder"
  done
  grep -q "wrote $dir/tiny.exr and $dir/tiny.png" "$log" ||
    fail "job $job: its log does not say it wrote the outputs"
  # The master's spool, and on the worker nodes the keys and the bundle cache: all removed.
  leftover=$(find "$scratch/tmp" -mindepth 1 -maxdepth 1 -name "prismfarm-*$job*")
  [ -z "$leftover" ] || fail "job $job left behind: $leftover"
  sed 's/^/  | /' "$log"
}

# The script's own default, three nodes: the master on the first, a worker on each other one
# (the srun step), each named after its node. The tiny job may be done before the second
# worker joins, so the workers are counted where they start, and one must have joined.
run_job three
first=$(sed -n 's/^prismfarm.sbatch: master on \([^ ]*\) .*/\1/p' "$log")
[ -n "$first" ] || fail "job $job: the log does not name the master's node"
# Under load the tiny job can end before srun has started the step's second task, which the
# script's cleanup then cancels: so at least one of the other nodes must show its worker, and
# none may run on the master's node.
started=0
for n in "${nodes[@]}"; do
  if [ "$n" = "$first" ]; then
    grep -q "as '$n' with" "$log" && fail "job $job: a worker ran on the master's node $n"
  else
    grep -q "worker: connecting to tcp://.* as '$n' with" "$log" && started=$((started + 1))
  fi
done
[ "$started" -ge 1 ] || fail "job $job: no worker started on the nodes other than the master's ($first)"
grep -q "worker [0-9]* '[a-z0-9]*' joined" "$log" || fail "job $job: no worker joined the master"
# One node: a worker beside the master.
run_job one --nodes=1
first=$(sed -n 's/^prismfarm.sbatch: master on \([^ ]*\) .*/\1/p' "$log")
grep -q "worker [0-9]* '$first' joined" "$log" || fail "job $job: no worker joined on the one node '$first'"
echo "$me: passed"
