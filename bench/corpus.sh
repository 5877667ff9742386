#!/usr/bin/env bash
# The pbrt-v4 corpus against pbrt-v4's own renders (docs/compatibility.md): renders every scene
# file of ../shared/pbrt-scenes (beside the clone) at its reference's size with
# `prismfarm render --direct`, twice (seeds 1 and 2), and compares the seed-1 image with
# reference/<folder>__<name>.exr and with the seed-2 image through bench_accuracy_diff.
# Prints one Markdown row per scene:
#   scene | size | load | render | R / G / B mean ratio | 3 s.e. | 4x4 RMSE | expected | verdict
# load is the wall-clock time of the run less the renderer's own time ("in X s" of its summary:
# parse, mesh import, textures, Embree's build, and writing the outputs); render is that time.
# The 4x4 RMSE (bench_accuracy_diff's lum4: relative RMSE of luminance after a 4x4 box
# downsample, REFERENCE.md's definition) of ours against pbrt-v4's is explained by noise alone
# when it is near expected = sqrt(s_ours^2 + s_ref^2): s_ours = lum4(seed 1, seed 2) / sqrt 2
# (two independent renders differ by sqrt 2 times either's noise) and s_ref = REFERENCE.md's
# "seed-2 rel. RMSE 4x4" / sqrt 2 likewise. A channel's mean ratio matches when it is within 2 %
# of 1 or within 3 standard errors of the difference, se = sqrt(se_ours^2 + se_ref^2):
# se_ours = |seed 1 / seed 2 mean ratio - 1| / sqrt 2 for that channel (two independent means
# differ by sqrt 2 times either's error; one pair gives a rough estimate), se_ref = REFERENCE.md's
# "seed-2 mean diff (max over RGB)" / sqrt 2 (the reference's own pair, the same for R, G, B);
# the "3 s.e." column prints 3 se, the largest over R, G, B. The RMSE and expected columns
# carry their standard errors (bench_accuracy_diff's lum4_se, from the spread of the blocks'
# squared differences; expected's through d(expected^2) = s_ours d(s_ours), the reference's
# figure taken as exact): where a glint or a small light's edge carries most of the RMSE, one
# pair of renders gives it to tens of per cent. The RMSE is explained by noise when it is at
# most 1.25 expected (the estimates are uncertain by a few per cent even over many blocks, and
# a 4x4 block mean is not quite Gaussian where fireflies are) or when it exceeds expected by at
# most 2 standard errors of their difference, sqrt(se_rmse^2 + se_expected^2). Verdict: "match" when
# every channel's mean matches and the RMSE is explained by noise;
# "mean only" when the means match but the RMSE exceeds it (a difference in the image's detail
# that noise does not explain); "differs" otherwise.
# usage: bash bench/corpus.sh [--spp N] [--bin PRISMFARM] [--diff BENCH_ACCURACY_DIFF]
#        [--corpus DIR] [--only SUBSTRING]
#        (defaults: 32, build/cli/prismfarm, build/bench/bench_accuracy_diff,
#         ../shared/pbrt-scenes, every scene)
set -euo pipefail
cd "$(dirname "$0")/.."
spp=32 bin=build/cli/prismfarm diff=build/bench/bench_accuracy_diff corpus=../shared/pbrt-scenes only=
while [ $# -gt 0 ]; do
  case "$1" in
    --spp) spp=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --diff) diff=$2; shift 2 ;;
    --corpus) corpus=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    *) echo "corpus.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[ -d "$corpus/reference" ] || { echo "corpus.sh: no corpus at $corpus" >&2; exit 2; }
[ -x "$bin" ] && [ -x "$diff" ] || { echo "corpus.sh: build first (bash deploy/build.sh release)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
. bench/diff_fields.sh
echo "| scene | size | load | render | R / G / B mean ratio | 3 s.e. | 4x4 RMSE | expected | verdict |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for ref in "$corpus"/reference/*__*.exr; do
  base=${ref##*/}; base=${base%.exr}
  scene="$corpus/${base%%__*}/${base#*__}.pbrt"
  [ -f "$scene" ] || continue
  case "$base" in *"$only"*) ;; *) continue ;; esac
  row=$(awk -F'|' -v n="$base.exr" '{ f = $2; gsub(/ /, "", f); if (f == n) print }' "$corpus/reference/REFERENCE.md")
  size=$(awk -F'|' '{ gsub(/ /, "", $3); print $3 }' <<<"$row")
  ref_rmse=$(awk -F'|' '{ gsub(/[ %]/, "", $9); print $9 / 100 }' <<<"$row")
  ref_mean=$(awk -F'|' '{ gsub(/[ %]/, "", $8); print $8 / 100 }' <<<"$row")
  name="${base/__//}.pbrt"
  start=$(date +%s.%N)
  if ! msg=$("$bin" render "$scene" --direct --res "$size" --spp "$spp" --seed 1 -o "$tmp/a.exr" --quiet 2>&1); then
    echo "| $name | $size | - | - | - | - | - | - | refused: $(grep -v warning <<<"$msg" | head -1) |"
    continue
  fi
  end=$(date +%s.%N)
  render_s=$(sed -n 's/.* rays in \([0-9.]*\) s.*/\1/p' <<<"$msg" | tail -1)
  "$bin" render "$scene" --direct --res "$size" --spp "$spp" --seed 2 -o "$tmp/b.exr" --quiet >/dev/null 2>&1
  vs_ref=$("$diff" "$tmp/a.exr" "$ref")
  vs_seed=$("$diff" "$tmp/a.exr" "$tmp/b.exr")
  awk -v name="$name" -v size="$size" -v wall="$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')" \
      -v render="${render_s:-0}" -v r="$(kv "$vs_ref" r_ratio)" -v g="$(kv "$vs_ref" g_ratio)" \
      -v b="$(kv "$vs_ref" b_ratio)" -v rmse="$(kv "$vs_ref" lum4)" -v ours="$(kv "$vs_seed" lum4)" \
      -v theirs="$ref_rmse" -v ref_mean="$ref_mean" -v r2="$(kv "$vs_seed" r_ratio)" \
      -v g2="$(kv "$vs_seed" g_ratio)" -v b2="$(kv "$vs_seed" b_ratio)" \
      -v rmse_se="$(kv "$vs_ref" lum4_se)" -v ours_se="$(kv "$vs_seed" lum4_se)" '
      function abs(x) { return x < 0 ? -x : x }
      # 3 standard errors of (ours - reference) / reference for a channel whose seed-1 over
      # seed-2 mean ratio is q.
      function tol3(q) { return 3 * sqrt((q - 1) * (q - 1) / 2 + ref_mean * ref_mean / 2) }
      function ok(x, q) { return abs(x - 1) < 0.02 || abs(x - 1) <= tol3(q) }
      BEGIN {
        expected = sqrt(ours * ours / 2 + theirs * theirs / 2)
        # standard errors ("-" from bench_accuracy_diff reads as 0: no allowance)
        ours_se += 0; rmse_se += 0
        exp_se = expected > 0 ? ours * ours_se / 2 / expected : 0
        noise = rmse <= 1.25 * expected || rmse - expected <= 2 * sqrt(rmse_se ^ 2 + exp_se ^ 2)
        means = ok(r, r2) && ok(g, g2) && ok(b, b2)
        t = tol3(r2); if (tol3(g2) > t) t = tol3(g2); if (tol3(b2) > t) t = tol3(b2)
        verdict = means ? (noise ? "match" : "mean only") : "differs"
        printf "| %s | %s | %.1f s | %.1f s | %.4f / %.4f / %.4f | %.2f %% | %.3f ± %.3f | %.3f ± %.3f | %s |\n",
          name, size, wall - render, render, r, g, b, 100 * t, rmse, rmse_se, expected, exp_se, verdict }'
  rm -f "$tmp"/a.* "$tmp"/b.*
done
