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
# CMake 3.25 (Debian 12) gives a pkg-config target's "-isystem" directory (libzmq's
# /usr/include/mit-krb5) to the compiler one way on a folder's first configure and another way
# on every later one (FindPkgConfig moves it out of the cached flags only on the first run). A
# second build.sh in the same folder -- deploy/test.sh after deploy/demo.sh, as CI runs them --
# then recompiled net/, dashboard/, master/ and cli/ and re-linked prismfarm with link-time
# optimisation, minutes of CI for the same program. A new folder is configured twice, so that
# every later configure agrees with the flags it was built with.
[ -f "$dir/CMakeCache.txt" ] || cmake -S . -B "$dir" "${flags[@]}" -DPRISMFARM_WERROR=ON >/dev/null
cmake -S . -B "$dir" "${flags[@]}" -DPRISMFARM_WERROR=ON >/dev/null
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$dir" -j "$(nproc)" "${targets[@]}"
