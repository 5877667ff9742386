#!/usr/bin/env bash
# Builds the libFuzzer harnesses (tests/fuzz, PRISMFARM_FUZZ=ON, clang with ASan + UBSan) in
# build-fuzz/ and runs each for SECONDS on a scratch copy of its seed corpus (the committed
# corpus never grows). Any crash, leak, sanitizer report, timeout (10 s on one input) or
# out-of-memory (2 GiB) fails the script; the input that caused it is kept in
# build-fuzz/fuzz-artifacts/ with the fuzzer's log. docs/fuzzing.md explains the rest.
# usage: deploy/fuzz.sh [SECONDS]   (default: $PRISMFARM_FUZZ_SECONDS, else 20; the build folder
#        is $PRISMFARM_FUZZ_BUILD_DIR, else build-fuzz; harnesses at once: $PRISMFARM_FUZZ_JOBS,
#        else the number of cores)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-${PRISMFARM_FUZZ_SECONDS:-20}}
case "$seconds" in
  '' | *[!0-9]*) echo "fuzz.sh: SECONDS must be a whole number, got '$seconds'" >&2; exit 2 ;;
esac
for tool in clang clang++; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "fuzz.sh: $tool not found: install the Debian packages clang and libclang-rt-14-dev" \
         "(or run: sudo bash deploy/install-deps.sh)" >&2
    exit 1
  fi
done

dir=${PRISMFARM_FUZZ_BUILD_DIR:-build-fuzz}
# Only the harnesses and the two libraries they link are built (not the renderer, the farm or
# the tests): about a minute on two cores.
CC=clang CXX=clang++ cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPRISMFARM_FUZZ=ON \
  >/dev/null
# One build of the five (not one after another: each would end on its own link, a core idle).
cmake --build "$dir" --target fuzz_pbrt fuzz_ply fuzz_proto fuzz_http fuzz_bsdf -j "$(nproc)"

# name, -max_len: a scene seed is up to 3.5 kB, a PLY or message seed under 1 kB, an HTTP
# request under 200 bytes (8 kB leaves room for the body limit, 4 kB), a .bsdf seed under 3 kB;
# longer inputs only slow the search down.
harnesses=("fuzz_pbrt 8192" "fuzz_ply 4096" "fuzz_proto 4096" "fuzz_http 8192" "fuzz_bsdf 8192")
artifacts=$dir/fuzz-artifacts
rm -rf "$artifacts"
mkdir -p "$artifacts"
# Scratch files of the harnesses (their scene and bundle folders) go here and are removed.
scratch=$(mktemp -d "${TMPDIR:-/tmp}/prismfarm-fuzz.XXXXXX")
trap 'rm -rf "$scratch"' EXIT

# Each harness is one process on one core (libFuzzer without -jobs/-workers), so they run side by
# side, as many at once as there are cores ($PRISMFARM_FUZZ_JOBS sets another number): each still
# gets SECONDS of a core to itself, as when they ran one after another, and the whole takes
# about ceil(5 / cores) x SECONDS instead of 5 x SECONDS.
lanes=${PRISMFARM_FUZZ_JOBS:-$(nproc)}
case "$lanes" in
  '' | *[!0-9]* | 0) echo "fuzz.sh: PRISMFARM_FUZZ_JOBS must be a whole number above 0, got '$lanes'" >&2
                     exit 2 ;;
esac
# One harness: its scratch corpus, its log, and its exit status in $artifacts/NAME.status.
fuzz_one() {
  local name=$1 max_len=$2
  local corpus=$scratch/corpus-$name log=$artifacts/$name.log rc=0
  mkdir -p "$corpus"
  cp tests/fuzz/corpus/"$name"/* "$corpus"/
  # detect_leaks: a leak is a failure; the harness's own exit paths free everything.
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 TMPDIR=$scratch \
    "$dir/tests/fuzz/$name" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -max_len="$max_len" -dict="tests/fuzz/${name#fuzz_}.dict" -print_final_stats=1 \
    -artifact_prefix="$artifacts/$name-" "$corpus" >"$log" 2>&1 || rc=$?
  echo "$rc" >"$artifacts/$name.status"
}

running=0
for h in "${harnesses[@]}"; do
  read -r name max_len <<<"$h"
  if [ "$running" -ge "$lanes" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  echo "== fuzz: $name for ${seconds} s (seeds: $(ls tests/fuzz/corpus/"$name" | wc -l)) =="
  fuzz_one "$name" "$max_len" &
  running=$((running + 1))
done
wait

failed=0
for h in "${harnesses[@]}"; do
  read -r name max_len <<<"$h"
  log=$artifacts/$name.log
  if [ "$(cat "$artifacts/$name.status" 2>/dev/null)" = 0 ]; then
    grep -E '^stat::number_of_executed_units|^Done ' "$log" | sed "s/^/  $name: /" || true
  else
    failed=1
    echo "fuzz.sh: $name FAILED; its last lines (full log: $log):" >&2
    tail -n 40 "$log" >&2
    ls "$artifacts"/"$name"-* 2>/dev/null | sed 's/^/  reproducer: /' >&2 || true
  fi
done
if [ "$failed" -ne 0 ]; then
  echo "fuzz.sh: a fuzzer found a failure; rerun one input with: $dir/tests/fuzz/NAME FILE" >&2
  exit 1
fi
echo "== fuzz: all harnesses ran ${seconds} s without a failure =="
