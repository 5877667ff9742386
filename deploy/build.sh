#!/usr/bin/env bash
# Configures and builds prismfarm into build/ (Release) or build-asan/ (PRISMFARM_SANITIZE=ON).
# usage: deploy/build.sh [release|asan]
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-release}
case "$kind" in
  release) dir=build; flags=(-DCMAKE_BUILD_TYPE=Release) ;;
  asan) dir=build-asan; flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DPRISMFARM_SANITIZE=ON) ;;
  *) echo "build.sh: expected 'release' or 'asan', got '$kind'" >&2; exit 2 ;;
esac
cmake -S . -B "$dir" "${flags[@]}" -DPRISMFARM_WERROR=ON >/dev/null
cmake --build "$dir" -j "$(nproc)"
