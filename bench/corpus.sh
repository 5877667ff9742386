#!/usr/bin/env bash
# The pbrt-v4 corpus against pbrt-v4's own renders (docs/compatibility.md): renders every scene
# file of ../shared/pbrt-scenes (beside the clone) at its reference's size with
# `prismfarm render --direct`, --seeds N times (seeds 1..N, default 2), and compares the seed-1
# image with reference/<folder>__<name>.exr and every pair of seeds' images with each other
# through bench_accuracy_diff.
# Prints one Markdown row per scene:
#   scene | size | load | render | R / G / B mean ratio | 3 s.e. | 4x4 RMSE | expected | verdict
# load is the seed-1 run's "loaded in L s" of its summary (parse, mesh import, textures,
# Embree's build); render is its "in X s" (photon pass, camera pass, writing the outputs).
# The 4x4 RMSE (bench_accuracy_diff's lum4: relative RMSE of luminance after a 4x4 box
# downsample, REFERENCE.md's definition) of ours against pbrt-v4's is explained by noise alone
# when it is near expected = sqrt(s_ours^2 + s_ref^2): s_ours^2 = the mean over the pairs of
# seeds of lum4(seed i, seed j)^2 / 2 (two independent renders differ by sqrt 2 times either's
# noise; over all pairs this is the seeds' sample variance, N - 1 degrees of freedom) and
# s_ref = REFERENCE.md's
# "seed-2 rel. RMSE 4x4" / sqrt 2 likewise. A channel's mean ratio matches when it is within 2 %
# of 1 or within 3 standard errors of the difference, se = sqrt(se_ours^2 + se_ref^2):
# se_ours^2 = the mean over the pairs of seeds of (seed i / seed j mean ratio - 1)^2 / 2 for that
# channel (two independent means differ by sqrt 2 times either's error; one pair, --seeds 2,
# gives a rough estimate, N seeds one with N - 1 degrees of freedom), se_ref = REFERENCE.md's
# "seed-2 mean diff (max over RGB)" / sqrt 2 (the reference's own pair, the same for R, G, B);
# the "3 s.e." column prints 3 se, the largest over R, G, B. The RMSE and expected columns
# carry their standard errors (bench_accuracy_diff's lum4_se, from the spread of the blocks'
# squared differences; expected's through d(expected^2) = s_ours d(s_ours), the reference's
# figure taken as exact, with s_ours's pairs' standard errors pooled in quadrature and divided
# by sqrt(N - 1)): where a glint or a small light's edge carries most of the RMSE, one pair of
# renders gives it to tens of per cent, and --seeds 3 or more narrows it. The RMSE is explained by noise when it is at
# most 1.25 expected (the estimates are uncertain by a few per cent even over many blocks, and
# a 4x4 block mean is not quite Gaussian where fireflies are) or when it exceeds expected by at
# most 2 standard errors of their difference, sqrt(se_rmse^2 + se_expected^2). Verdict: "match" when
# every channel's mean matches and the RMSE is explained by noise;
# "mean only" when the means match but the RMSE exceeds it (a difference in the image's detail
# that noise does not explain); "differs" otherwise.
# usage: bash bench/corpus.sh [--spp N] [--seeds N] [--bin PRISMFARM] [--diff BENCH_ACCURACY_DIFF]
#        [--corpus DIR] [--only SUBSTRING]
#        (defaults: 32, 2, build/cli/prismfarm, build/bench/bench_accuracy_diff,
#         ../shared/pbrt-scenes, every scene)
set -euo pipefail
cd "$(dirname "$0")/.."
spp=32 seeds=2 bin=build/cli/prismfarm diff=build/bench/bench_accuracy_diff corpus=../shared/pbrt-scenes only=
while [ $# -gt 0 ]; do
  case "$1" in
    --spp) spp=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --diff) diff=$2; shift 2 ;;
    --corpus) corpus=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    *) echo "corpus.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[[ "$seeds" =~ ^[0-9]+$ ]] && [ "$seeds" -ge 2 ] || { echo "corpus.sh: --seeds takes an integer >= 2" >&2; exit 2; }
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
  if ! msg=$("$bin" render "$scene" --direct --res "$size" --spp "$spp" --seed 1 -o "$tmp/s1.exr" --quiet 2>&1); then
    echo "| $name | $size | - | - | - | - | - | - | refused: $(grep -v warning <<<"$msg" | head -1) |"
    continue
  fi
  load_s=$(sed -n 's/.*loaded in \([0-9.]*\) s;.*/\1/p' <<<"$msg" | tail -1)
  render_s=$(sed -n 's/.* rays in \([0-9.]*\) s.*/\1/p' <<<"$msg" | tail -1)
  for ((k = 2; k <= seeds; k++)); do
    "$bin" render "$scene" --direct --res "$size" --spp "$spp" --seed "$k" -o "$tmp/s$k.exr" --quiet >/dev/null 2>&1
  done
  vs_ref=$("$diff" "$tmp/s1.exr" "$ref")
  # Every pair of seeds: lum4, its standard error and the R, G, B mean ratios, space-separated.
  p_l= p_se= p_r= p_g= p_b=
  for ((i = 1; i < seeds; i++)); do
    for ((k = i + 1; k <= seeds; k++)); do
      d=$("$diff" "$tmp/s$i.exr" "$tmp/s$k.exr")
      p_l+="$(kv "$d" lum4) " p_se+="$(kv "$d" lum4_se) "
      p_r+="$(kv "$d" r_ratio) " p_g+="$(kv "$d" g_ratio) " p_b+="$(kv "$d" b_ratio) "
    done
  done
  awk -v name="$name" -v size="$size" -v load="${load_s:-0}" -v seeds="$seeds" \
      -v render="${render_s:-0}" -v r="$(kv "$vs_ref" r_ratio)" -v g="$(kv "$vs_ref" g_ratio)" \
      -v b="$(kv "$vs_ref" b_ratio)" -v rmse="$(kv "$vs_ref" lum4)" -v p_l="$p_l" -v p_se="$p_se" \
      -v theirs="$ref_rmse" -v ref_mean="$ref_mean" -v p_r="$p_r" -v p_g="$p_g" -v p_b="$p_b" \
      -v rmse_se="$(kv "$vs_ref" lum4_se)" '
      function abs(x) { return x < 0 ? -x : x }
      # The mean over the pairs of seeds of (x - c)^2 ("-" from bench_accuracy_diff reads as 0).
      function msq(list, c,   v, n, i, t) {
        n = split(list, v, " "); t = 0
        for (i = 1; i <= n; i++) t += (v[i] - c) ^ 2
        return n > 0 ? t / n : 0 }
      # 3 standard errors of (ours - reference) / reference for a channel whose pairs of seeds
      # have mean ratios list.
      function tol3(list) { return 3 * sqrt(msq(list, 1) / 2 + ref_mean * ref_mean / 2) }
      function ok(x, list) { return abs(x - 1) < 0.02 || abs(x - 1) <= tol3(list) }
      BEGIN {
        ours = sqrt(msq(p_l, 0))
        expected = sqrt(ours * ours / 2 + theirs * theirs / 2)
        # standard errors ("-" from bench_accuracy_diff reads as 0: no allowance); those of the pairs
        # pooled in quadrature, N - 1 degrees of freedom
        ours_se = sqrt(msq(p_se, 0) / (seeds - 1)); rmse_se += 0
        exp_se = expected > 0 ? ours * ours_se / 2 / expected : 0
        noise = rmse <= 1.25 * expected || rmse - expected <= 2 * sqrt(rmse_se ^ 2 + exp_se ^ 2)
        means = ok(r, p_r) && ok(g, p_g) && ok(b, p_b)
        t = tol3(p_r); if (tol3(p_g) > t) t = tol3(p_g); if (tol3(p_b) > t) t = tol3(p_b)
        verdict = means ? (noise ? "match" : "mean only") : "differs"
        printf "| %s | %s | %.1f s | %.1f s | %.4f / %.4f / %.4f | %.2f %% | %.3f ± %.3f | %.3f ± %.3f | %s |\n",
          name, size, load, render, r, g, b, 100 * t, rmse, rmse_se, expected, exp_se, verdict }'
  rm -f "$tmp"/s*.*
done
