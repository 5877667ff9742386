#!/usr/bin/env bash
# Sets up and runs every test: installs dependencies, builds the Release and the
# AddressSanitizer+UBSan configurations, runs ctest in both, then runs the fuzzers briefly.
# Each stage prints how long it took, and a table of them ends the run (CI has 20 minutes).
set -euo pipefail
cd "$(dirname "$0")/.."

stages=()
# stage NAME COMMAND...: runs COMMAND under a heading and records its wall time.
stage() {
  local name=$1 t=$SECONDS
  shift
  echo "== $name ($(date -u +%H:%M:%S) UTC) =="
  "$@"
  stages+=("$(printf '%-34s %5d s' "$name" $((SECONDS - t)))")
  echo "== $name: $((SECONDS - t)) s =="
}

# What the builds need first; the packages only the tests use (Slurm, munge, Prometheus,
# Chromium: some 300 MB to download and unpack, a minute of CI) come meanwhile, beside the two
# builds, which need none of them. One apt run at a time still: the second starts after the
# first. Only where no password can be asked (root, or sudo without one): else in the
# foreground, as before, so that sudo's prompt is not lost among the compiler's lines.
stage "install-deps (build)" bash deploy/install-deps.sh
deps=""
if [ "$(id -u)" -eq 0 ] || sudo -n true 2>/dev/null; then
  deps_log=$(mktemp "${TMPDIR:-/tmp}/prismfarm-deps.XXXXXX")
  trap 'rm -f "$deps_log" "$deps_log.s"' EXIT
  (
    t=$SECONDS rc=0
    bash deploy/install-deps.sh --test || rc=$?
    echo "$((SECONDS - t))" >"$deps_log.s"
    exit "$rc"
  ) >"$deps_log" 2>&1 &
  deps=$!
else
  stage "install-deps --test" bash deploy/install-deps.sh --test
fi
stage "build: release (build)" bash deploy/build.sh release
stage "build: asan (build-asan)" bash deploy/build.sh asan
if [ -n "$deps" ]; then
  deps_rc=0
  wait "$deps" || deps_rc=$?
  echo "== install-deps --test (beside the builds) =="
  sed 's/^/  /' "$deps_log"
  if [ "$deps_rc" -ne 0 ]; then
    echo "test.sh: installing the test packages failed (exit $deps_rc): its output is above" >&2
    exit 1
  fi
  stages+=("$(printf '%-34s %5d s' "install-deps --test (beside them)" "$(cat "$deps_log.s")")")
fi

jobs=$(nproc)
asan_ctest() {
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir build-asan --output-on-failure -j "$jobs"
}
stage "tests: sanitizer build (build-asan)" asan_ctest
stage "tests: release build (build)" ctest --test-dir build --output-on-failure -j "$jobs"
# libFuzzer harnesses (tests/fuzz): each runs PRISMFARM_FUZZ_SECONDS (default 20) on its seeds.
stage "fuzz: build and run" bash deploy/fuzz.sh

echo "== test.sh: the stages' wall times =="
printf '  %s\n' "${stages[@]}"
echo "  total                              $(printf '%5d' "$SECONDS") s"
