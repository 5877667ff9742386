#!/usr/bin/env bash
# The pbrt-v4 corpus against pbrt-v4's own renders (docs/compatibility.md): renders every scene
# file of ../shared/pbrt-scenes (beside the clone) at its reference's size with
# `prismfarm render --direct`, and compares each with reference/<folder>__<name>.exr through
# bench_accuracy_diff (channel mean ratios, relative RMSE of luminance). Prints one Markdown row
# per scene: scene | size | wall-clock seconds | figures, or the refusal.
# usage: bash bench/corpus.sh [--spp N] [--bin PRISMFARM] [--diff BENCH_ACCURACY_DIFF]
#        [--corpus DIR]     (defaults: 32, build/cli/prismfarm, build/bench/bench_accuracy_diff,
#                            ../shared/pbrt-scenes)
set -euo pipefail
cd "$(dirname "$0")/.."
spp=32 bin=build/cli/prismfarm diff=build/bench/bench_accuracy_diff corpus=../shared/pbrt-scenes
while [ $# -gt 0 ]; do
  case "$1" in
    --spp) spp=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --diff) diff=$2; shift 2 ;;
    --corpus) corpus=$2; shift 2 ;;
    *) echo "corpus.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[ -d "$corpus/reference" ] || { echo "corpus.sh: no corpus at $corpus" >&2; exit 2; }
[ -x "$bin" ] && [ -x "$diff" ] || { echo "corpus.sh: build first (bash deploy/build.sh release)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| scene | size | time | figures |"
echo "| --- | --- | --- | --- |"
for ref in "$corpus"/reference/*__*.exr; do
  base=${ref##*/}; base=${base%.exr}
  scene="$corpus/${base%%__*}/${base#*__}.pbrt"
  [ -f "$scene" ] || continue
  size=$(awk -F'|' -v n="$base.exr" '{gsub(/ /,"",$2); if ($2 == n) {gsub(/ /,"",$3); print $3}}' "$corpus/reference/REFERENCE.md")
  start=$(date +%s.%N)
  if msg=$("$bin" render "$scene" --direct --res "$size" --spp "$spp" -o "$tmp/out.exr" --quiet 2>&1 >/dev/null); then
    end=$(date +%s.%N)
    echo "| ${base/__//}.pbrt | $size | $(awk -v a="$start" -v b="$end" 'BEGIN{printf "%.1f s", b - a}') | $("$diff" "$tmp/out.exr" "$ref") |"
  else
    echo "| ${base/__//}.pbrt | $size | - | refused: $(echo "$msg" | grep -v warning | head -1) |"
  fi
  rm -f "$tmp"/out.*
done
