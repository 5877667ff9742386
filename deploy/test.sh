#!/usr/bin/env bash
# Sets up and runs every test: installs dependencies, builds the Release and the
# AddressSanitizer+UBSan configurations, runs ctest in both, then runs the fuzzers briefly.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh --test
bash deploy/build.sh release
bash deploy/build.sh asan
jobs=$(nproc)
echo "== tests: sanitizer build (build-asan) =="
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j "$jobs"
echo "== tests: release build (build) =="
ctest --test-dir build --output-on-failure -j "$jobs"
# libFuzzer harnesses (tests/fuzz): each runs PRISMFARM_FUZZ_SECONDS (default 20) on its seeds.
bash deploy/fuzz.sh
