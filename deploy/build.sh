#!/usr/bin/env bash
# Configures and builds prismfarm into build/ (Release) or build-asan/ (PRISMFARM_SANITIZE=ON).
# usage: deploy/build.sh [release|asan] [TARGET...]
# With targets, only those are built (the demo builds only `prismfarm`); without, everything
# (tests, fuzzers, benches).
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-release}
[ $# -gt 0 ] && shift
case "$kind" in
  release) dir=build; flags=(-DCMAKE_BUILD_TYPE=Release) ;;
  asan) dir=build-asan; flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DPRISMFARM_SANITIZE=ON) ;;
  *) echo "build.sh: expected 'release' or 'asan', got '$kind'" >&2; exit 2 ;;
esac
cmake -S . -B "$dir" "${flags[@]}" -DPRISMFARM_WERROR=ON >/dev/null
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$dir" -j "$(nproc)" "${targets[@]}"
