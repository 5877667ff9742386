#!/usr/bin/env bash
# The master at scale (docs/performance.md, "The master at scale"): one `prismfarm master` on
# loopback TCP against 100, 250 and 500 simulated workers (bench/farm_sim.c: one process of N
# DEALER connections that answer tasks with prepared tiles, so that the master's own cost is
# what is measured), on a job of 10 000 tiles (800x800 pixels in 8x8 tiles, 4 spp: 3 passes,
# 30 000 tasks), while 10 % of the workers disconnect at seeded points. Two runs per worker
# count:
#   offered  each simulated worker (1 thread, so 2 tasks held) keeps each task N/RATE seconds:
#            RATE results/s offered (default 2000), the goal the master must keep up with;
#   flat out each task answered at once: the results/s the master sustains, and what limits it.
# Reports per run the results/s, the master's CPU (whole process and its main thread; share of
# one core and microseconds per task), the turnaround (a result sent to the next task received
# by that worker: the master's merge and dispatch as a worker sees them), the master's peak RSS,
# and the check that no task was lost or merged twice (the simulator's EXR check), and the
# dashboard's GET /api/workers during the run (the master with --http on loopback: 100 requests
# from one curl 3 s into the job; the median time per request and per worker listed, whose
# flatness across the worker counts says the listing is not quadratic in them). Writes the
# table into docs/performance.md between its "farm-scale:begin" and "farm-scale:end" markers
# and the plot of master CPU against workers to docs/farm_scale.png (gnuplot).
#
# usage: bash bench/farm_scale.sh [--build DIR] [--no-build] [--no-docs] [--points "100 250 500"]
#                                 [--runs "offered flatout"] [--rate 2000] [--res 800x800]
#                                 [--tile 8] [--spp 4] [--bin PRISMFARM]
#   --build DIR  Release build folder (default build, as deploy/build.sh release makes it)
#   --no-build   use DIR's binaries as they are
#   --no-docs    print the table only (and write the plot in the scratch folder)
#   --bin FILE   another prismfarm for the master (an older build, to compare)
# About 3 minutes on 2 idle cores. The simulator and the master share the machine's cores.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$ROOT/build
WRITE_DOCS=1
DO_BUILD=1
POINTS="100 250 500"
RUNS="offered flatout"
MASTER_BIN=
RATE=2000
RES=800x800
TILE=8
SPP=4
while (($#)); do
  case $1 in
    --build) BUILD=${2:-}; shift 2 ;;
    --no-build) DO_BUILD=0; shift ;;
    --no-docs) WRITE_DOCS=0; shift ;;
    --points) POINTS=${2:-}; shift 2 ;;
    --runs) RUNS=${2:-}; shift 2 ;;
    --bin) MASTER_BIN=${2:-}; shift 2 ;;
    --rate) RATE=${2:-}; shift 2 ;;
    --res) RES=${2:-}; shift 2 ;;
    --tile) TILE=${2:-}; shift 2 ;;
    --spp) SPP=${2:-}; shift 2 ;;
    -h|--help) sed -n '2,25p' "$0"; exit 0 ;;
    *) echo "bench/farm_scale.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ $RATE =~ ^[1-9][0-9]*$ ]] || { echo "bench/farm_scale.sh: --rate expects a positive integer" >&2; exit 2; }

if ((DO_BUILD)); then
  echo "== building Release into $BUILD" >&2
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" -j2 --target prismfarm bench_farm_sim >/dev/null
fi
BIN=$BUILD/cli/prismfarm
SIM=$BUILD/bench/bench_farm_sim
[[ -n $MASTER_BIN ]] && BIN=$MASTER_BIN
for f in "$BIN" "$SIM"; do
  [[ -x $f ]] || { echo "bench/farm_scale.sh: no $f (build it, or drop --no-build)" >&2; exit 1; }
done

# Each connection is a descriptor in the master and two in the simulator.
ulimit -n "$(ulimit -Hn)"
WORK=$(mktemp -d /tmp/farm_scale.XXXXXX)
MASTER=
cleanup() {
  [[ -n $MASTER ]] && kill "$MASTER" 2>/dev/null && wait "$MASTER" 2>/dev/null
  rm -rf "$WORK"
}
trap cleanup EXIT

NPROC=$(nproc)
CPU=$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')
BUCKETS=16 # bench/farm_scale.pbrt's Film

# GET /api/workers 100 times over one curl, 3 s into the run (the workers have joined): writes
# "dash_workers=N dash_ms_p50=MS dash_us_per_worker=US" to $2, nothing if the master answers no
# list by then.
dash_probe() {
  local url=${1%/}/api/workers out=$2 listed urls=()
  sleep 3
  listed=$(curl -sf --max-time 10 "$url" | grep -o '"id":' | wc -l) || return 0
  ((listed > 0)) || return 0
  for _ in $(seq 100); do urls+=(-o /dev/null "$url"); done
  curl -sf --max-time 60 -w '%{time_total}\n' "${urls[@]}" |
    sort -g | awk -v n="$listed" '{ t[NR] = $1 } END {
      if (NR) printf "dash_workers=%d dash_ms_p50=%.3f dash_us_per_worker=%.3f\n", n,
        1000 * t[int((NR + 1) / 2)], 1e6 * t[int((NR + 1) / 2)] / n }' >"$out"
}

# One run: N workers, hold in ms; appends the simulator's line, tagged, to $WORK/runs.
run() {
  local n=$1 hold=$2 tag=$3 spool=$WORK/spool-$1-$3
  # Every simulated worker connects from 127.0.0.1: the per-host connection bound (512 by
  # default, docs/security.md "Connections") is lifted where the master has one.
  local extra=()
  local help
  help=$("$BIN" master --help 2>&1 || true) # whole, not piped into grep -q (pipefail)
  grep -q max-connections-per-host <<<"$help" && extra=(--max-connections-per-host 0)
  grep -q -- '--http ' <<<"$help" && extra+=(--http 127.0.0.1:0)
  "$BIN" master --workers 'tcp://127.0.0.1:*' --clients 'tcp://127.0.0.1:*' --insecure \
    --tile "$TILE" --spool "$spool" "${extra[@]}" 2>"$WORK/master-$n-$tag.log" &
  MASTER=$!
  for _ in $(seq 200); do [[ -s $spool/endpoints ]] && break; sleep 0.05; done
  [[ -s $spool/endpoints ]] || { echo "bench/farm_scale.sh: the master did not start:" >&2; cat "$WORK/master-$n-$tag.log" >&2; exit 1; }
  local wep cep line
  wep=$(awk '$1 == "workers" { print $2 }' "$spool/endpoints")
  cep=$(awk '$1 == "clients" { print $2 }' "$spool/endpoints")
  echo "== $n workers, $tag (hold $hold ms)" >&2
  local http dash=
  http=$(awk '$1 == "http" { print $2 }' "$spool/endpoints")
  if [[ -n $http ]] && command -v curl >/dev/null; then
    dash_probe "$http" "$WORK/dash-$n-$tag" &
    dash=$!
  fi
  if ! line=$("$SIM" --workers "$wep" --clients "$cep" --scene "$ROOT/bench/farm_scale.pbrt" \
      --res "$RES" --spp "$SPP" --buckets "$BUCKETS" --tile "$TILE" --n "$n" --hold-ms "$hold" \
      --disconnect 0.1 --seed "$n" --master-pid "$MASTER" --timeout 900 --quiet); then
    echo "bench/farm_scale.sh: the run of $n workers ($tag) failed: $line" >&2
  fi
  if [[ -n $dash ]]; then
    wait "$dash" || true
    [[ -s $WORK/dash-$n-$tag ]] && line="$line $(cat "$WORK/dash-$n-$tag")"
  fi
  echo "$line" >&2
  echo "tag=$tag $line" >>"$WORK/runs"
  kill "$MASTER"
  wait "$MASTER" || true
  MASTER=
  grep -c ' lost (' "$WORK/master-$n-$tag.log" | sed "s/^/   workers the master declared lost: /" >&2 || true
}

: >"$WORK/runs"
for n in $POINTS; do
  for r in $RUNS; do
    case $r in
      offered) run "$n" "$(awk -v n="$n" -v r="$RATE" 'BEGIN { printf "%.1f", 1000 * n / r }')" offered ;;
      flatout) run "$n" 0 flatout ;;
      *) echo "bench/farm_scale.sh: --runs takes offered and flatout, not '$r'" >&2; exit 2 ;;
    esac
  done
done

# key=value fields of a run line
field() { tr ' ' '\n' <<<"$2" | awk -F= -v k="$1" '$1 == k { print $2 }'; }

{
  echo "Measured by \`bench/farm_scale.sh\` on $CPU, $NPROC cores shared by the master and the"
  echo "simulator (and by whatever else the machine runs); $(date -u +%Y-%m-%d). Job: $RES pixels"
  echo "in ${TILE}x$TILE tiles ($(( (${RES%x*} + TILE - 1) / TILE * ((${RES#*x} + TILE - 1) / TILE) )) tiles), $SPP spp,"
  echo "$BUCKETS buckets, journal on; 10 % of the workers disconnect during the job. *offered*: the"
  echo "workers answer $RATE results/s between them; *flat out*: each task at once. *Steady"
  echo "results/s*: between 5 % and 95 % of the tasks answered; *job*: first task to done, with the"
  echo "tail where the last tasks wait for a silent worker's 3 s timeout. *Turnaround*: a result"
  echo "sent to the next task received by that worker, for the results sent between 5 % and"
  echo "95 % (the master merges a result in the loop turn that reads it and fills the freed slot"
  echo "at that turn's end); *task cycle*: a task received to the task its result made room for,"
  echo "i.e. assign to merge and the next assignment. CPU"
  echo "from /proc/PID/stat (main thread:"
  echo "/proc/PID/task/PID/stat), from the first HELLO to the job's end; *waiting for a CPU*: the"
  echo "share of that time the main thread was runnable but on a run queue (schedstat): the"
  echo "machine's other work, not the master's."
  echo
  echo "| workers | run | steady results/s | job (s) | master CPU (cores) | main thread (cores) | main thread waiting for a CPU | CPU µs/task | main µs/task | turnaround p50 / p99 (ms) | task cycle p50 / p99 (ms) | peak RSS (MB) | disconnects | answered twice | lost | pixels wrong |"
  echo "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
  while read -r l; do
    tag=$(field tag "$l")
    [[ $tag == offered ]] && tag="offered $RATE/s" || tag="flat out"
    printf '| %s | %s | %.0f | %.1f | %.2f | %.2f | %.0f %% | %.0f | %.0f | %.1f / %.0f | %.0f / %.0f | %.0f | %s | %s | %s | %s |\n' \
      "$(field workers "$l")" "$tag" "$(field steady_results_per_s "$l")" "$(field run_s "$l")" "$(field cpu_core_share "$l")" \
      "$(field main_core_share "$l")" "$(awk -v v="$(field main_runqueue_share "$l")" 'BEGIN { print 100 * v }')" \
      "$(field cpu_us_per_task "$l")" "$(field main_us_per_task "$l")" \
      "$(field turnaround_ms_p50 "$l")" "$(field turnaround_ms_p99 "$l")" \
      "$(field cycle_ms_p50 "$l")" "$(field cycle_ms_p99 "$l")" "$(field rss_peak_mb "$l")" \
      "$(field disconnects "$l")" "$(field answered_twice "$l")" "$(field lost "$l")" \
      "$(field pixels_bad "$l")"
  done <"$WORK/runs"
  if grep -q dash_ms_p50 "$WORK/runs"; then
    echo
    echo "The dashboard's \`GET /api/workers\` during the runs (100 requests over one curl, 3 s"
    echo "into the job; the median): a listing that stays linear in the workers keeps the time per"
    echo "worker flat."
    echo
    echo "| workers | run | workers listed | ms per request | µs per worker listed |"
    echo "| ---: | --- | ---: | ---: | ---: |"
    while read -r l; do
      [[ -n $(field dash_ms_p50 "$l") ]] || continue
      tag=$(field tag "$l")
      [[ $tag == offered ]] && tag="offered $RATE/s" || tag="flat out"
      printf '| %s | %s | %s | %.2f | %.2f |\n' "$(field workers "$l")" "$tag" \
        "$(field dash_workers "$l")" "$(field dash_ms_p50 "$l")" "$(field dash_us_per_worker "$l")"
    done <"$WORK/runs"
  fi
} >"$WORK/report.md"
cat "$WORK/report.md"

# The plot: the master's CPU (share of one core) against the worker count, both runs.
if command -v gnuplot >/dev/null; then
  for tag in offered flatout; do
    while read -r l; do
      [[ $(field tag "$l") == "$tag" ]] || continue
      echo "$(field workers "$l") $(field cpu_core_share "$l") $(field main_core_share "$l") $(field steady_results_per_s "$l") $(field cpu_us_per_task "$l") $(field main_us_per_task "$l")"
    done <"$WORK/runs" >"$WORK/$tag.dat"
  done
  OUT=$ROOT/docs/farm_scale.png
  ((WRITE_DOCS)) || OUT=$WORK/farm_scale.png
  gnuplot <<EOF
set terminal pngcairo size 1300,560 font "DejaVu Sans,11" noenhanced
set output '$OUT'
set multiplot layout 1,2 title "The master against simulated workers ($RES in ${TILE}x$TILE tiles, $SPP spp, 10 % disconnecting; $NPROC shared cores)" font "DejaVu Sans,13"
set grid lc rgb '#dddddd'
set xlabel "simulated workers"
set xrange [0:*]
set yrange [0:*]
set key bottom right box opaque font "DejaVu Sans,9"
set title "master CPU (cores: 1 = one core busy)"
set ylabel "cores"
plot '$WORK/offered.dat' using 1:2 with linespoints lw 2 pt 7 lc rgb '#1f77b4' title "whole process, $RATE results/s offered", \
     '$WORK/offered.dat' using 1:3 with linespoints lw 2 pt 6 dt 2 lc rgb '#1f77b4' title "main thread, $RATE results/s offered", \
     '$WORK/flatout.dat' using 1:2 with linespoints lw 2 pt 7 lc rgb '#d62728' title "whole process, flat out", \
     '$WORK/flatout.dat' using 1:3 with linespoints lw 2 pt 6 dt 2 lc rgb '#d62728' title "main thread, flat out"
set title "master CPU per task (µs); one core at 2000 results/s is 500 µs"
set ylabel "µs per task"
set yrange [0:600]
set arrow 1 from graph 0, first 500 to graph 1, first 500 nohead dt 3 lc rgb 'gray40' back
plot '$WORK/offered.dat' using 1:5 with linespoints lw 2 pt 7 lc rgb '#1f77b4' title "whole process, $RATE results/s offered", \
     '$WORK/offered.dat' using 1:6 with linespoints lw 2 pt 6 dt 2 lc rgb '#1f77b4' title "main thread, $RATE results/s offered", \
     '$WORK/flatout.dat' using 1:5 with linespoints lw 2 pt 7 lc rgb '#d62728' title "whole process, flat out", \
     '$WORK/flatout.dat' using 1:6 with linespoints lw 2 pt 6 dt 2 lc rgb '#d62728' title "main thread, flat out"
unset multiplot
EOF
  echo "== plot: $OUT" >&2
else
  echo "== gnuplot is not installed: no plot (apt-get install gnuplot-nox, then run again)" >&2
fi

if ((WRITE_DOCS)); then
  DOC=$ROOT/docs/performance.md
  if ! grep -q '<!-- farm-scale:begin -->' "$DOC"; then
    printf '\n<!-- farm-scale:begin -->\n<!-- farm-scale:end -->\n' >>"$DOC"
  fi
  awk -v rep="$WORK/report.md" '
    /<!-- farm-scale:begin -->/ { print; while ((getline l < rep) > 0) print l; skip = 1; next }
    /<!-- farm-scale:end -->/ { skip = 0 }
    !skip { print }' "$DOC" >"$WORK/doc.md"
  cp "$WORK/doc.md" "$DOC"
  echo "== docs/performance.md updated" >&2
fi
