#!/usr/bin/env bash
# The farm's benchmarks (docs/performance.md), side by side in one run:
#   1. overhead: one worker behind a master on loopback TCP (separate processes), and
#      `prismfarm render` (the farm in one process), against `prismfarm render --direct` (plain
#      threads) on the same job; target: within 5 %;
#   2. scaling: two workers of one thread against one worker of one thread; target >= 1.8x on 2
#      cores; --direct with 1 and 2 threads for reference;
#   3. bytes on the wire per rendered pixel: the kernel's byte counters of the master's worker
#      connection (ss -ti), against the protocol's payload (docs/protocol.md);
#   4. rays/s of `prismfarm render --direct` for every scenes/*.pbrt at a small size.
# Each figure is the median of --reps repetitions, the modes of one repetition run one after
# the other so that they share the machine's state. Prints the tables and rewrites the part of
# docs/performance.md between its "bench:begin" and "bench:end" markers.
#
# usage: bash bench/farm.sh [--reps N] [--build DIR] [--no-build] [--no-docs]
#   --reps N    repetitions of every timing (default 5): about 10 minutes on 2 idle cores
#   --build DIR Release build folder (default build-bench in the repository); built first
#   --no-build  use DIR/cli/prismfarm as it is
#   --no-docs   print the tables only
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
REPS=5
BUILD=$ROOT/build-bench
WRITE_DOCS=1
DO_BUILD=1
while (($#)); do
  case $1 in
    --reps) REPS=${2:-}; shift 2 ;;
    --build) BUILD=${2:-}; shift 2 ;;
    --no-build) DO_BUILD=0; shift ;;
    --no-docs) WRITE_DOCS=0; shift ;;
    -h|--help) sed -n '2,19p' "$0"; exit 0 ;;
    *) echo "bench/farm.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ $REPS =~ ^[1-9][0-9]*$ ]] || { echo "bench/farm.sh: --reps expects a positive integer" >&2; exit 2; }
command -v ss >/dev/null || { echo "bench/farm.sh: needs ss (iproute2) for the wire bytes" >&2; exit 1; }

if ((DO_BUILD)); then
  echo "== building Release into $BUILD" >&2
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" -j"$(nproc)" --target prismfarm >/dev/null
fi
BIN=$BUILD/cli/prismfarm
[[ -x $BIN ]] || { echo "bench/farm.sh: no $BIN (build it, or drop --no-build)" >&2; exit 1; }

NPROC=$(nproc)
CPU=$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')
HZ=$(getconf CLK_TCK)
WORK=$(mktemp -d /tmp/prismfarm-bench-XXXXXX)
PIDS=()
cleanup() {
  local p
  for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${PIDS[@]}"; do wait "$p" 2>/dev/null || true; done
  rm -rf "$WORK"
}
trap cleanup EXIT

# ---------------------------------------------------------------- helpers

# A sleep without a fork (read on a pipe nobody writes), so that waiting for a job costs the
# render threads no CPU.
exec {NAP_FD}<> <(:)
nap() { read -r -t "$1" -u "$NAP_FD" _ || true; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", b - a }'; }
add() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", a + b }'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", a / b }'; }
# "median min max" of the arguments.
stats() { printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END {
  m = NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2; printf "%.3f %.3f %.3f\n", m, v[1], v[NR] }'; }
med() { stats "$@" | cut -d' ' -f1; }
least() { stats "$@" | cut -d' ' -f2; }

# CPU seconds (user + system) of a running process, from /proc/PID/stat fields 14 and 15.
cpu_of() { awk -v hz="$HZ" '{ sub(/^.*\) /, ""); printf "%.3f\n", ($12 + $13) / hz }' "/proc/$1/stat"; }
# CHILD_CPU: CPU seconds of every child this shell has waited for, from bash's `times` (second
# line), which must run in this shell itself (in a pipe or $(...) it would run in a subshell
# that has no children) and is read back from a file.
children_cpu() {
  local file=$WORK/times.$BASHPID
  times >"$file"
  CHILD_CPU=$(awk 'NR == 2 { n = 0; for (i = 1; i <= 2; i++) { split($i, p, /[ms]/); n += p[1] * 60 + p[2] }
                             printf "%.3f", n }' "$file")
}
load() { cut -d' ' -f1 /proc/loadavg; }
# Busy CPU ticks of the whole machine (user, nice, system, irq, softirq, steal).
busy() { awk '$1 == "cpu" { print $2 + $3 + $4 + $7 + $8 + $9 }' /proc/stat; }

# ---------------------------------------------------------------- the jobs

# A job is a scene and the options that size it. tiny0 is tests/data/render/tiny.pbrt as
# shipped (24x16, 4 spp): next to no rendering, so its times are the fixed costs of each mode.
# The others take a few seconds on one core; prism96 is prism24 with 4x the samples, so the
# two show how the overhead falls as a job grows. prism512 is a job of the length a farm is
# for (10 s of CPU, still small): a pass re-sends every pixel, so the farm's bytes grow with
# log2(spp) while the work grows with spp.
declare -A SCENE=([tiny0]=tests/data/render/tiny.pbrt
                  [prism24]=scenes/prism.pbrt [prism96]=scenes/prism.pbrt
                  [prism512]=scenes/prism.pbrt [tiny128]=tests/data/render/tiny.pbrt)
declare -A ARGS=([tiny0]="" [prism24]="--res 240x180 --spp 24" [prism96]="--res 240x180 --spp 96"
                 [prism512]="--res 120x90 --spp 512"
                 [tiny128]="--res 192x128 --spp 128")
OVERHEAD_JOBS=(tiny0 prism24 prism96 tiny128 prism512)
SCALING_JOBS=(prism24 tiny128 prism512)
WIRE_JOBS=(prism24 prism96 tiny128)
RAYS_ARGS="--res 160x120 --spp 16"
RAYS_REPS=3
for f in "$ROOT"/scenes/*.pbrt; do
  SCENE[rays:$(basename "$f")]=scenes/$(basename "$f") ARGS[rays:$(basename "$f")]=$RAYS_ARGS
done

# ---------------------------------------------------------------- the three ways to render
# Each prints "WALL CPU" in seconds (a farm job also the master's CPU), and runs in a subshell
# of its own (see measure), so that children_cpu counts its processes only.

# `prismfarm render --direct`: process start to exit (scene load, render, EXR and PNG written).
t_direct() { # job threads
  local t0=$EPOCHREALTIME wall
  # shellcheck disable=SC2086
  "$BIN" render "$ROOT/${SCENE[$1]}" ${ARGS[$1]} --direct --threads "$2" -o "$WORK/direct.exr" \
    --quiet >"$WORK/direct.out"
  wall=$(elapsed "$t0" "$EPOCHREALTIME")
  children_cpu
  echo "$wall $CHILD_CPU"
}

# `prismfarm render`: a master and one worker in the process over inproc://.
t_inproc() { # job threads
  local t0=$EPOCHREALTIME wall
  # shellcheck disable=SC2086
  "$BIN" render "$ROOT/${SCENE[$1]}" ${ARGS[$1]} --workers 1 --threads "$2" -o "$WORK/inproc.exr" \
    --quiet >/dev/null
  wall=$(elapsed "$t0" "$EPOCHREALTIME")
  children_cpu
  echo "$wall $CHILD_CPU"
}

declare -A CEP SPOOL WPORT FPIDS
# A standing farm: a master and N workers of T threads, separate processes on loopback TCP.
start_farm() { # name workers threads [master options...]
  local name=$1 n=$2 t=$3 spool=$WORK/$1 wep cep i
  shift 3
  "$BIN" master --workers 'tcp://127.0.0.1:*' --clients 'tcp://127.0.0.1:*' --spool "$spool" --insecure \
    "$@" 2>"$WORK/$name-master.log" &
  PIDS+=($!)
  FPIDS[$name]=$!
  for ((i = 0; i < 500; i++)); do [[ -s $spool/endpoints ]] && break; nap 0.01; done
  wep=$(awk '$1 == "workers" { print $2 }' "$spool/endpoints")
  cep=$(awk '$1 == "clients" { print $2 }' "$spool/endpoints")
  for ((i = 1; i <= n; i++)); do
    "$BIN" worker --connect "$wep" --insecure --threads "$t" --name "$name-w$i" --cache "$WORK/$name-cache$i" \
      --quiet 2>>"$WORK/$name-workers.log" &
    PIDS+=($!)
    FPIDS[$name]+=" $!"
  done
  for ((i = 0; i < 500; i++)); do
    (($("$BIN" workers --master "$cep" --insecure --json | grep -c '"state": "idle"') == n)) && break
    nap 0.02
  done
  CEP[$name]=$cep SPOOL[$name]=$spool WPORT[$name]=${wep##*:}
}

farm_cpu() { # name: CPU seconds of its master and workers so far
  local p sum=0
  for p in ${FPIDS[$1]}; do sum=$(add "$sum" "$(cpu_of "$p")"); done
  echo "$sum"
}

# A job on a standing farm: from `prismfarm submit` to the final EXR in the master's spool
# (written atomically, so its existence means the job is done). `submit --wait` would add its
# own start, the answer to its STATUS long poll and the fetch. CPU: the client's, plus what the
# master and workers used meanwhile; then the master's alone. Leaves the job id in $WORK/last-job.
t_farm() { # farm job
  local t0=$EPOCHREALTIME c0 m0 c1 m1 id exr i wall master=${FPIDS[$1]%% *}
  c0=$(farm_cpu "$1")
  m0=$(cpu_of "$master")
  # shellcheck disable=SC2086
  id=$("$BIN" submit "$ROOT/${SCENE[$2]}" --master "${CEP[$1]}" --insecure --name bench ${ARGS[$2]})
  exr=${SPOOL[$1]}/jobs/$id/bench.exr
  for ((i = 0; ; i++)); do
    [[ -e $exr ]] && break
    # A failed job is looked for every 10 s only: a client process a second (its start alone
    # loads every library) took a few percent of the cores the workers were timed on.
    if ((i % 5000 == 4999)) && "$BIN" status "$id" --master "${CEP[$1]}" --insecure | grep -qE 'failed|cancelled'; then
      echo "bench/farm.sh: job $id on farm $1 did not complete:" >&2
      cat "$WORK/$1-master.log" >&2
      exit 1
    fi
    nap 0.002
  done
  wall=$(elapsed "$t0" "$EPOCHREALTIME")
  c1=$(farm_cpu "$1")
  m1=$(cpu_of "$master")
  echo "$id" >"$WORK/last-job"
  children_cpu
  echo "$wall $(add "$(elapsed "$c0" "$c1")" "$CHILD_CPU") $(elapsed "$m0" "$m1")"
}

# Runs one timing and appends its wall-clock and CPU seconds to W[key] and C[key] (and the
# master's CPU seconds to M[key] for a farm job).
declare -A W C M
measure() { # key command args...
  local key=$1 w c m
  shift
  read -r w c m < <("$@")
  [[ -n ${c:-} ]] || { echo "bench/farm.sh: '$*' failed" >&2; exit 1; }
  W[$key]+="$w " C[$key]+="$c " M[$key]+="${m:-0} "
}

# bytes_received and bytes_acked summed over the master's established connections on a port.
wire() { # port
  ss -tinH state established "( sport = :$1 )" | awk '
    { for (i = 1; i <= NF; i++) { split($i, kv, ":")
        if (kv[1] == "bytes_received") r += kv[2]; if (kv[1] == "bytes_acked") s += kv[2] } }
    END { printf "%d %d\n", r, s }'
}

LOAD0=$(load)
BUSY0=$(busy)
T0=$EPOCHREALTIME

# ---------------------------------------------------------------- 1. overhead

TN=$NPROC
echo "== overhead: $REPS repetitions, $TN threads" >&2
start_farm tcp1 1 "$TN"
# The same without the master's journal (docs/reliability.md): what keeping it costs.
start_farm tcpnj 1 "$TN" --no-journal
for j in "${OVERHEAD_JOBS[@]}"; do # warm-up: the worker fetches the scene, caches warm
  measure warm t_direct "$j" "$TN"
  measure warm t_farm tcp1 "$j"
  measure warm t_farm tcpnj "$j"
done
for ((r = 1; r <= REPS; r++)); do
  for j in "${OVERHEAD_JOBS[@]}"; do
    measure "direct|$j" t_direct "$j" "$TN"
    measure "inproc|$j" t_inproc "$j" "$TN"
    measure "tcp|$j" t_farm tcp1 "$j"
    measure "tcpnj|$j" t_farm tcpnj "$j"
  done
  echo "   repetition $r/$REPS done" >&2
done

# ---------------------------------------------------------------- 3. bytes on the wire

echo "== bytes on the wire" >&2
declare -A WIRE
for j in "${WIRE_JOBS[@]}"; do
  read -r r0 s0 < <(wire "${WPORT[tcp1]}")
  measure wire t_farm tcp1 "$j"
  read -r r1 s1 < <(wire "${WPORT[tcp1]}")
  # The master's log line for the job: "WxH, S spp, B buckets, T tiles x P passes".
  line=$(grep "job $(cat "$WORK/last-job") 'bench' submitted" "$WORK/tcp1-master.log")
  read -r xres yres spp nb tiles passes < <(sed -E \
    's/.*: ([0-9]+)x([0-9]+), ([0-9]+) spp, ([0-9]+) buckets, ([0-9]+) tiles x ([0-9]+) passes.*/\1 \2 \3 \4 \5 \6/' <<<"$line")
  WIRE[$j]="$xres $yres $spp $nb $tiles $passes $((r1 - r0)) $((s1 - s0))"
done

# ---------------------------------------------------------------- 2. scaling

echo "== scaling: $REPS repetitions" >&2
start_farm one 1 1
start_farm two 2 1
for j in "${SCALING_JOBS[@]}"; do measure warm t_farm one "$j"; measure warm t_farm two "$j"; done
for ((r = 1; r <= REPS; r++)); do
  for j in "${SCALING_JOBS[@]}"; do
    measure "one|$j" t_farm one "$j"
    measure "two|$j" t_farm two "$j"
    measure "direct1|$j" t_direct "$j" 1
    measure "direct2|$j" t_direct "$j" 2
  done
  echo "   repetition $r/$REPS done" >&2
done

# ---------------------------------------------------------------- 4. rays/s

echo "== rays/s of every scene" >&2
declare -A RAYS
for f in "$ROOT"/scenes/*.pbrt; do
  j=rays:$(basename "$f")
  for ((r = 1; r <= RAYS_REPS; r++)); do
    measure "$j" t_direct "$j" "$TN"
    # "N samples, X M rays in Y s (Z M rays/s); ..."
    RAYS[$j]+="$(sed -nE 's/.* \(([0-9.]+) M rays\/s\).*/\1/p' "$WORK/direct.out") "
  done
done

LOAD1=$(load)
# How much of the machine other processes took meanwhile: every busy tick, less this run's own
# CPU (the processes it waited for, and its standing farms).
BUSY1=$(busy)
children_cpu
OURS=$CHILD_CPU
for p in "${PIDS[@]}"; do OURS=$(add "$OURS" "$(cpu_of "$p")"); done
OTHERS=$(awk -v b0="$BUSY0" -v b1="$BUSY1" -v hz="$HZ" -v ours="$OURS" -v t0="$T0" -v t1="$EPOCHREALTIME" \
  'BEGIN { o = ((b1 - b0) / hz - ours) / (t1 - t0); printf "%.2f", o < 0 ? 0 : o }')
MINUTES=$(awk -v a="$T0" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.1f", (b - a) / 60 }')

# ---------------------------------------------------------------- report

# "median (min–max)" of a list of seconds.
cell() { local m lo hi; read -r m lo hi < <(stats $1); printf '%.2f (%.2f–%.2f)' "$m" "$lo" "$hi"; }
verdict() { awk -v v="$1" -v t="$2" -v op="$3" 'BEGIN { ok = op == "<=" ? v <= t : v >= t; print ok ? "**met**" : "**missed**" }'; }
job() { echo "\`${SCENE[$1]}${ARGS[$1]:+ ${ARGS[$1]}}\`"; }
# Ratio of two timings' medians, then of their minima: "1.050; 1.020".
ratios() { echo "$(ratio "$(med ${W[$1]})" "$(med ${W[$2]})"); $(ratio "$(least ${W[$1]})" "$(least ${W[$2]})")"; }

report() {
  local j f ri rf sp
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $NPROC cores ($CPU), Linux $(uname -r),"
  echo "commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)$([[ -z $(git -C "$ROOT" status --porcelain 2>/dev/null) ]] || echo ' with uncommitted changes'),"
  echo "Release build; $REPS repetitions per figure, shown as median (min–max) seconds. The run took"
  echo "$MINUTES minutes; other processes used **$OTHERS of the $NPROC cores** on average meanwhile (1-minute"
  echo "load average $LOAD0 before, $LOAD1 after). Ratios are given for the medians and, after the"
  echo "semicolon, for the minima (the least disturbed repetition); the verdict is the median's."
  echo
  echo "**Overhead of the farm** ($TN threads everywhere; target: within 5 % of --direct)"
  echo
  echo "| job | --direct | render (in-process farm) | TCP farm, 1 worker | in-process / direct | TCP / direct | CPU seconds: in-process / direct, TCP / direct | master CPU per job | target ≤ 1.05 |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  for j in "${OVERHEAD_JOBS[@]}"; do
    ri=$(ratio "$(med ${W[inproc|$j]})" "$(med ${W[direct|$j]})")
    rf=$(ratio "$(med ${W[tcp|$j]})" "$(med ${W[direct|$j]})")
    echo "| $(job "$j") | $(cell "${W[direct|$j]}") | $(cell "${W[inproc|$j]}") | $(cell "${W[tcp|$j]}")" \
      "| $(ratios "inproc|$j" "direct|$j") | $(ratios "tcp|$j" "direct|$j")" \
      "| $(ratio "$(med ${C[inproc|$j]})" "$(med ${C[direct|$j]})"), $(ratio "$(med ${C[tcp|$j]})" "$(med ${C[direct|$j]})")" \
      "| $(printf '%.2f s' "$(med ${M[tcp|$j]})")" \
      "| $([[ $j == tiny0 ]] && echo 'fixed costs, no target' || echo "in-process $(verdict "$ri" 1.05 '<='), TCP $(verdict "$rf" 1.05 '<=')") |"
  done
  echo
  echo "**The journal's cost** (the TCP farm above against one whose master runs --no-journal; the"
  echo "journal writes every result and a checkpoint of the image about once per pass)"
  echo
  echo "| job | TCP farm, journal | TCP farm, --no-journal | journal / none: wall; min | master CPU: journal, none |"
  echo "| --- | --- | --- | --- | --- |"
  for j in "${OVERHEAD_JOBS[@]}"; do
    echo "| $(job "$j") | $(cell "${W[tcp|$j]}") | $(cell "${W[tcpnj|$j]}") | $(ratios "tcp|$j" "tcpnj|$j")" \
      "| $(printf '%.2f s, %.2f s' "$(med ${M[tcp|$j]})" "$(med ${M[tcpnj|$j]})") |"
  done
  echo
  echo "**Scaling** (TCP farm, workers of 1 thread each; target: 2 workers ≥ 1.8x one worker)"
  echo
  echo "| job | 1 worker | 2 workers | speed-up | target ≥ 1.8 | --direct 1 thread | --direct 2 threads | speed-up | 1-worker farm / --direct 1 thread: wall, CPU |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  for j in "${SCALING_JOBS[@]}"; do
    sp=$(ratio "$(med ${W[one|$j]})" "$(med ${W[two|$j]})")
    echo "| $(job "$j") | $(cell "${W[one|$j]}") | $(cell "${W[two|$j]}") | $(ratios "one|$j" "two|$j")" \
      "| $(verdict "$sp" 1.8 '>=') | $(cell "${W[direct1|$j]}") | $(cell "${W[direct2|$j]}")" \
      "| $(ratios "direct1|$j" "direct2|$j")" \
      "| $(ratio "$(med ${W[one|$j]})" "$(med ${W[direct1|$j]})"), $(ratio "$(med ${C[one|$j]})" "$(med ${C[direct1|$j]})") |"
  done
  echo
  echo "**Bytes on the wire** (one job on the 1-worker TCP farm: the kernel's byte counters of the master's"
  echo "worker connection, \`ss -ti\` bytes_received and bytes_acked, i.e. TCP payload including ZMTP"
  echo "framing and heartbeats; against the tile payload of docs/protocol.md, passes × pixels ×"
  echo "(4·buckets + 24) bytes: float32 sums, float64 luminance sums, a uint64 count)"
  echo
  echo "| job | pixels | buckets | tiles × passes | worker → master, measured | tile payload | measured / payload | per pixel | per pixel and sample | master → worker |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  for j in "${WIRE_JOBS[@]}"; do
    local xres yres spp nb tiles passes recv sent px payload
    read -r xres yres spp nb tiles passes recv sent <<<"${WIRE[$j]}"
    px=$((xres * yres)) payload=$((passes * xres * yres * (4 * nb + 24)))
    echo "| $(job "$j") | $px | $nb | $tiles × $passes | $recv B | $payload B | $(ratio "$recv" "$payload")" \
      "| $(awk -v a="$recv" -v b="$px" 'BEGIN { printf "%.1f B", a / b }')" \
      "| $(awk -v a="$recv" -v b="$px" -v c="$spp" 'BEGIN { printf "%.2f B", a / b / c }') | $sent B |"
  done
  echo
  echo "**Rays per second** of \`prismfarm render SCENE --direct --threads $TN $RAYS_ARGS\` (median of $RAYS_REPS)"
  echo
  echo "| scene | seconds | M rays/s |"
  echo "| --- | --- | --- |"
  for f in "$ROOT"/scenes/*.pbrt; do
    j=rays:$(basename "$f")
    read -r m lo hi < <(stats ${RAYS[$j]})
    echo "| \`${SCENE[$j]}\` | $(cell "${W[$j]}") | $(printf '%.2f (%.2f–%.2f)' "$m" "$lo" "$hi") |"
  done
}

report >"$WORK/report.md"
cat "$WORK/report.md"

if ((WRITE_DOCS)); then
  DOC=$ROOT/docs/performance.md
  if ! grep -q '<!-- bench:begin -->' "$DOC" 2>/dev/null; then
    printf '\n<!-- bench:begin -->\n<!-- bench:end -->\n' >>"$DOC"
  fi
  awk -v rep="$WORK/report.md" '
    /<!-- bench:begin -->/ { print; while ((getline l < rep) > 0) print l; skip = 1; next }
    /<!-- bench:end -->/ { skip = 0 }
    !skip' "$DOC" >"$WORK/doc.md"
  cp "$WORK/doc.md" "$DOC"
  echo "== wrote the tables into $DOC" >&2
fi
