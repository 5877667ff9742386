#!/usr/bin/env bash
# Equal-error efficiency against pbrt-v4 (docs/performance.md, "Efficiency against pbrt-v4";
# issue 24): renders the scenes of ../shared/pbrt-scenes/reference/spp64/EFFICIENCY.md (beside
# the clone) at the size of their references (REFERENCE.md), --spp samples (default 64), with
# --seeds seeds (1..N, default 4), each with `prismfarm render --direct --threads 2` and with the
# in-process farm (`prismfarm render --threads 2`: a master and one worker of 2 threads over
# inproc://), the two modes alternating seed by seed so that a slow spell of the machine hits
# both. Every render's CPU time is its process's user + system seconds (bash's `times` in a
# subshell). ../shared/tools/equal_error.py, the method, computes from the --direct renders:
#   variance  relative variance of one image: mean over pixels and R, G, B of (a - b)^2 / 2
#             after a 4x4 box downsample, over the squared image mean, averaged over the pairs
#             of seeds (1-2, 3-4); pbrt-v4's from its own four renders in reference/spp64;
#   CPU s     the mean over seeds of one image's CPU seconds; pbrt-v4's from EFFICIENCY.md
#             (measured on this machine kind with 2 threads, not beside ours);
#   efficiency  1 / (variance x CPU s), ours over pbrt-v4's;
#   mean ratio  the R, G, B means of our images over pbrt-v4's (within 2 %: same expected image).
# The farm renders the same pixels as --direct (docs/farm.md, "Same pixels"), so its variance is
# the same; the table gives its CPU over --direct's (the farm's overhead on jobs of this size).
# Then the demo scenes scenes/jewel.pbrt and scenes/crystal.pbrt at their own settings (size,
# spp, integrator; --direct, 2 threads, seeds 1 and 2): their relative error at a fixed CPU
# budget of --budget seconds (default 60), by Monte Carlo's law error ~ 1 / sqrt(work):
#   error at budget = error x sqrt(CPU s / budget), with CPU s the mean of the two renders and
#   error either the render's own estimate (seed 1's "relative error estimate", the relative
#   RMSE of the per-pixel mean luminance, docs/farm.md "Accuracy"), or measured: the relative
#   RMSE of one image's pixel luminance, sqrt(mean_p (Y1 - Y2)^2 / 2) / mean Y, from the two
#   seeds (independent of the estimator, which an adaptive sampler could bias).
# CPU time grows with the machine's load (other processes' cache and memory traffic, SMT), so
# the date and `uptime` are printed with the tables: on a shared machine CPU figures are upper
# bounds; variances do not depend on load.
# Needs python3 with OpenImageIO and numpy (deploy/install-deps.sh installs them). About
# 40 minutes on 2 idle cores with the farm, 20 without.
# Scenes whose noise figure one small region decides get more seeds (--scene-seeds, default
# veach-mis=16): on veach-mis a 4x4 block around the smallest, brightest lamp carries about
# three quarters of the variance, and two pairs of seeds of it spread over a factor of ten
# (docs/performance.md, "veach-mis: more seeds"); our variance is then the mean over 8 pairs.
# pbrt-v4's stays that of its own 4 renders (reference/spp64), the comparison's floor of noise.
# With --pbrt BIN, pbrt-v4 is measured beside ours instead of read from reference/spp64: for each
# scene and seed 1-4 it renders the scene the way the stored references were made
# (REFERENCE.md, spp64/EFFICIENCY.md: a copy of the file that changes only the Film's
# resolution to the reference's size and adds "bool savefp16" [false], rendered as
# `pbrt --nthreads 2 --spp N --seed S --outfile X.exr copy.pbrt`), right after our renders of
# the same seed (direct, farm, pbrt-v4, next seed ...), so that both CPU figures see the same
# load; equal_error.py then takes pbrt-v4's variance from those four images and its CPU from
# their mean (--pbrt-cpu). The row gives these side-by-side figures, and its last column the
# efficiency against the stored references (reference/spp64 images, EFFICIENCY.md's CPU) from
# the same renders of ours.
# usage: bash bench/efficiency.sh [--only SUBSTRING] [--seeds N] [--bin PRISMFARM] [--spp N]
#        [--skip-farm] [--skip-demo] [--budget S] [--corpus DIR] [--keep DIR]
#        [--scene-seeds SUBSTRING=N ...] [--pbrt PBRT]
#        (defaults: every scene, 4, build/cli/prismfarm, 64, farm on, demo scenes on, 60,
#         ../shared/pbrt-scenes; --keep copies every render into DIR; veach-mis=16)
#   --scene-seeds SUBSTRING=N  N seeds (even, at least --seeds) for the corpus scenes whose
#                     <folder>__<stem> holds SUBSTRING; repeatable; "--scene-seeds none" drops
#                     the defaults
#   --only SUBSTRING  only the corpus scenes whose <folder>__<stem> holds SUBSTRING, and the demo
#                     scenes only when their name holds it
set -euo pipefail
cd "$(dirname "$0")/.."
spp=64 seeds=4 bin=build/cli/prismfarm corpus=../shared/pbrt-scenes only= farm=1 demo=1 budget=60 keep= pbrt=
scene_seeds=(veach-mis=16)
while [ $# -gt 0 ]; do
  case "$1" in
    --scene-seeds)
      if [ "$2" = none ]; then scene_seeds=()
      elif [[ "$2" =~ ^[^=]+=[0-9]+$ ]]; then scene_seeds+=("$2")
      else echo "efficiency.sh: --scene-seeds takes SUBSTRING=N or none" >&2; exit 2; fi
      shift 2 ;;
    --only) only=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --skip-farm) farm=0; shift ;;
    --skip-demo) demo=0; shift ;;
    --budget) budget=$2; shift 2 ;;
    --corpus) corpus=$2; shift 2 ;;
    --keep) keep=$2; shift 2 ;;
    --pbrt) pbrt=$2; shift 2 ;;
    -h|--help) sed -n '2,56p' "$0"; exit 0 ;;
    *) echo "efficiency.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ "$seeds" =~ ^[0-9]+$ ]] && [ "$seeds" -ge 2 ] && [ $((seeds % 2)) -eq 0 ] ||
  { echo "efficiency.sh: --seeds takes an even integer >= 2 (equal_error.py pairs them)" >&2; exit 2; }
[[ "$spp" =~ ^[1-9][0-9]*$ ]] || { echo "efficiency.sh: --spp takes a positive integer" >&2; exit 2; }
[[ "$budget" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "efficiency.sh: --budget takes seconds" >&2; exit 2; }
eff_md=$corpus/reference/spp64/EFFICIENCY.md
tool=$corpus/../tools/equal_error.py
[ -f "$eff_md" ] || { echo "efficiency.sh: no $eff_md" >&2; exit 2; }
[ -f "$tool" ] || { echo "efficiency.sh: no $tool" >&2; exit 2; }
[ -x "$bin" ] || { echo "efficiency.sh: no $bin (build first, or --bin)" >&2; exit 2; }
[ -z "$pbrt" ] || [ -x "$pbrt" ] || { echo "efficiency.sh: --pbrt $pbrt is not an executable" >&2; exit 2; }
# Debian's python3 (the packages are Debian's), else the first on PATH.
py=
for p in /usr/bin/python3 python3; do
  if "$p" -c 'import numpy, OpenImageIO' 2>/dev/null; then py=$p; break; fi
done
[ -n "$py" ] || { echo "efficiency.sh: needs python3-numpy and python3-openimageio (deploy/install-deps.sh)" >&2; exit 2; }
[ -z "$keep" ] || mkdir -p "$keep"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# A copy of the binary: a rebuild of the tree it comes from during the run (tens of minutes)
# would otherwise change it half-way, or refuse to run while it is being written.
bin_rev=$(git -C "$(dirname "$bin")" rev-parse --short HEAD 2>/dev/null || echo '?')
cp "$bin" "$tmp/prismfarm"
bin_in=$bin bin=$tmp/prismfarm
if [ -n "$pbrt" ]; then
  cp "$pbrt" "$tmp/pbrt"
  pbrt_in=$pbrt pbrt=$tmp/pbrt
  # equal_error.py reads pbrt-v4's four images from ../pbrt-scenes/reference/spp64 beside itself:
  # a copy of it beside a folder of this run's pbrt-v4 renders uses them with the same method.
  mkdir -p "$tmp/eq/tools" "$tmp/eq/pbrt-scenes/reference/spp64"
  cp "$tool" "$tmp/eq/tools/equal_error.py"
fi

# pbrt_copy SCENE WxH OUT: OUT = SCENE with the Film's xresolution / yresolution set to W and H and
# "bool savefp16" [ false ] added (REFERENCE.md), in a folder of links to SCENE's folder's
# entries so that the file's relative paths resolve as beside the original.
pbrt_copy() {
  local d
  d=$(dirname "$3")
  mkdir -p "$d"
  for e in "$(dirname "$1")"/*; do ln -sfn "$(realpath "$e")" "$d/"; done
  "$py" - "$1" "$2" "$3" <<'EOF'
import re, sys
src, size, out = sys.argv[1:4]
w, h = size.split('x')
t = open(src).read()
m = re.search(r'Film\s+"[a-z]+"', t)
if not m: sys.exit(f'{src}: no Film statement')
for name, v in (('xresolution', w), ('yresolution', h)):
    pat = r'("integer\s+' + name + r'"\s*)\[?\s*\d+\s*\]?'
    if re.search(pat, t): t = re.sub(pat, lambda mm: mm.group(1) + f'[ {v} ]', t, count=1)
    else: t = t[:m.end()] + f' "integer {name}" [ {v} ]' + t[m.end():]
    m = re.search(r'Film\s+"[a-z]+"', t)
t = t[:m.end()] + ' "bool savefp16" [ false ]' + t[m.end():]
open(out, 'w').write(t)
EOF
}

# cpu_of OUT_VAR CMD...: runs CMD (its output to $tmp/msg), sets OUT_VAR to its user + system
# seconds (the children's line of `times` in a subshell that ran only CMD); fails as CMD does.
cpu_of() {
  local var=$1 t
  shift
  t=$( ("$@" >"$tmp/msg" 2>&1 || exit 1; times) | tail -1) || return 1
  printf -v "$var" '%s' "$(awk '{ for (i = 1; i <= 2; i++) { split($i, a, /[ms]/); t += a[1] * 60 + a[2] }
                                  printf "%.2f", t }' <<<"$t")"
}

echo "Efficiency against pbrt-v4: $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores, $spp spp, seeds 1-$seeds (more where a row says), 2 threads"
echo "binary: $bin_in (the tree it was built from is at $bin_rev)"
[ -z "$pbrt" ] || echo "pbrt-v4: $pbrt_in, rendered beside ours (seeds 1-4, alternating scene by scene and seed by seed)"
echo "load before: $(uptime)"
echo "method: $(realpath "$tool"): $(sed -n '/^Noise:/,/^with pbrt-v4/p' "$tool" | tr '\n' ' ' | sed 's/  */ /g')"
echo
if [ -n "$pbrt" ]; then
  echo "| scene | variance ours / pbrt-v4 (side by side) | CPU s ours / pbrt-v4 (side by side) | efficiency ours/pbrt-v4 (side by side) | farm CPU / direct CPU | mean ratio R/G/B | against the stored references: efficiency (pbrt-v4 variance, CPU s) |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
else
  echo "| scene | variance ours / pbrt-v4 | CPU s ours / pbrt-v4 | efficiency ours/pbrt-v4 | farm CPU / direct CPU | mean ratio R/G/B |"
  echo "| --- | --- | --- | --- | --- | --- |"
fi
tags=$(awk -F'|' '/^\| [a-z].*__/ { t = $2; gsub(/ /, "", t); print t }' "$eff_md")
for tag in $tags; do
  case "$tag" in *"$only"*) ;; *) continue ;; esac
  scene="$corpus/${tag%%__*}/${tag#*__}.pbrt"
  size=$(awk -F'|' -v n="$tag.exr" '{ f = $2; gsub(/ /, "", f); if (f == n) { gsub(/ /, "", $3); print $3 } }' \
    "$corpus/reference/REFERENCE.md")
  if [ ! -f "$scene" ] || [ -z "$size" ]; then
    echo "| $tag | - | - | - | - | no scene file or size |"
    continue
  fi
  n_seeds=$seeds
  for e in "${scene_seeds[@]}"; do
    case "$tag" in *"${e%%=*}"*) ((${e#*=} > n_seeds)) && n_seeds=${e#*=} ;; esac
  done
  ((n_seeds % 2 == 0)) || n_seeds=$((n_seeds + 1))
  direct_cpu=() farm_cpu=() pbrt_cpu=() imgs=() failed=
  [ -z "$pbrt" ] || pbrt_copy "$scene" "$size" "$tmp/pbrt_scene/${tag%%__*}/.efficiency_${tag#*__}.pbrt"
  for ((s = 1; s <= n_seeds; s++)); do
    args=(render "$scene" --res "$size" --spp "$spp" --seed "$s" --threads 2 --quiet)
    if ! cpu_of c "$bin" "${args[@]}" --direct -o "$tmp/d$s.exr"; then
      failed="direct seed $s: $(grep -v warning "$tmp/msg" | head -1)"; break
    fi
    direct_cpu+=("$c") imgs+=("$tmp/d$s.exr")
    if ((farm)); then
      if ! cpu_of c "$bin" "${args[@]}" -o "$tmp/f$s.exr"; then
        failed="farm seed $s: $(grep -v warning "$tmp/msg" | head -1)"; break
      fi
      farm_cpu+=("$c")
    fi
    if [ -n "$pbrt" ] && ((s <= 4)); then
      if ! cpu_of c "$pbrt" --nthreads 2 --spp "$spp" --seed "$s" \
        --outfile "$tmp/eq/pbrt-scenes/reference/spp64/${tag}__s$s.exr" \
        "$tmp/pbrt_scene/${tag%%__*}/.efficiency_${tag#*__}.pbrt"; then
        failed="pbrt-v4 seed $s: $(grep -iv warning "$tmp/msg" | grep . | tail -1)"; break
      fi
      pbrt_cpu+=("$c")
    fi
  done
  if [ -n "$failed" ]; then
    echo "| $tag | - | - | - | - | refused: $failed |"
    continue
  fi
  if [ -n "$keep" ]; then
    for f in "$tmp"/d*.exr; do cp "$f" "$keep/${tag}__${f##*/}"; done
    cp "$tmp/d1.png" "$keep/${tag}__d1.png" 2>/dev/null || true
  fi
  cpu=$(printf '%s\n' "${direct_cpu[@]}" | awk '{ t += $1 } END { printf "%.2f", t / NR }')
  fcpu=-
  ((farm)) && fcpu=$(printf '%s\n' "${farm_cpu[@]}" | awk '{ t += $1 } END { printf "%.2f", t / NR }')
  stored=
  if [ -n "$pbrt" ]; then
    if ((${#pbrt_cpu[@]} < 4)); then
      echo "| $tag | - | - | - | - | pbrt-v4 rendered ${#pbrt_cpu[@]} of 4 seeds (--seeds below 4?) | - |"; continue
    fi
    pcpu=$(printf '%s\n' "${pbrt_cpu[@]}" | awk '{ t += $1 } END { printf "%.2f", t / NR }')
    sline=$("$py" "$tool" "$tag" "$cpu" "${imgs[@]}" 2>&1) || sline=
    stored=$(awk -v line="$sline" 'BEGIN { n = split(line, w, /[ ;()]+/)
      for (i = 1; i <= n; i++) {
        if (w[i] == "relvar") vt = w[i + 4]
        if (w[i] == "CPU") ct = w[i + 5]
        if (w[i] == "efficiency") eff = w[i + 2] }
      if (eff == "") print "-"; else printf "%s (%s, %s)", eff, vt, ct }')
    line=$("$py" "$tmp/eq/tools/equal_error.py" --pbrt-cpu "$pcpu" "$tag" "$cpu" "${imgs[@]}" 2>&1) || {
      echo "| $tag | - | - | - | - | equal_error.py: $line | - |"; continue; }
    [ -z "$keep" ] || for s in 1 2 3 4; do
      cp "$tmp/eq/pbrt-scenes/reference/spp64/${tag}__s$s.exr" "$keep/${tag}__pbrt_s$s.exr"; done
    rm -f "$tmp/eq/pbrt-scenes/reference/spp64/${tag}"__s*.exr
  else
    line=$("$py" "$tool" "$tag" "$cpu" "${imgs[@]}" 2>&1) || {
      echo "| $tag | - | - | - | - | equal_error.py: $line |"; continue; }
  fi
  # tag: relvar ours A pbrt-v4 B (ratio X); CPU s ours C pbrt-v4 D; mean ratio R/G/B r/g/b; efficiency ours/pbrt-v4 E
  label=$tag
  ((n_seeds == seeds)) || label="$tag ($n_seeds seeds)"
  awk -v tag="$label" -v line="$line" -v fcpu="$fcpu" -v cpu="$cpu" -v stored="$stored" 'BEGIN {
    n = split(line, w, /[ ;()]+/)
    for (i = 1; i <= n; i++) {
      if (w[i] == "relvar") { vo = w[i + 2]; vt = w[i + 4]; vr = w[i + 6] }
      if (w[i] == "CPU") { ct = w[i + 5] }
      if (w[i] == "R/G/B") mr = w[i + 1]
      if (w[i] == "efficiency") eff = w[i + 2] }
    f = fcpu == "-" ? "-" : sprintf("%.2f (%.1f s)", fcpu / cpu, fcpu)
    printf "| %s | %s / %s (%sx) | %.1f / %s (%.2fx) | **%s** | %s | %s |%s\n",
      tag, vo, vt, vr, cpu, ct, cpu / ct, eff, f, mr, stored == "" ? "" : " " stored " |" }'
  rm -f "$tmp"/d*.* "$tmp"/f*.*
done

if ((demo)); then
  echo
  echo "Demo scenes at their own settings (--direct, 2 threads, seeds 1 and 2); error at a budget of"
  echo "$budget CPU s = error x sqrt(CPU s / $budget) (error ~ 1 / sqrt(work)); own = seed 1's relative"
  echo "error estimate, measured = sqrt(mean_p (Y1 - Y2)^2 / 2) / mean Y from the two seeds' pixels"
  echo
  echo "| scene | spp | CPU s per image | own estimate | measured | own at $budget CPU s | measured at $budget CPU s |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  for name in jewel crystal; do
    case "$name" in *"$only"*) ;; *) [ -n "$only" ] && continue ;; esac
    c1= c2=
    if ! cpu_of c1 "$bin" render "scenes/$name.pbrt" --direct --threads 2 --seed 1 -o "$tmp/j1.exr"; then
      echo "| $name | - | - | - | - | - | refused: $(grep -v warning "$tmp/msg" | head -1) |"; continue
    fi
    est=$(sed -n 's/.*spp, relative error estimate \([0-9.]*\).*/\1/p' "$tmp/msg" | tail -1)
    sppd=$(sed -n 's/^\([0-9]*\) of \([0-9]*\) spp.*/\1/p' "$tmp/msg" | tail -1)
    cpu_of c2 "$bin" render "scenes/$name.pbrt" --direct --threads 2 --seed 2 -o "$tmp/j2.exr" || {
      echo "| $name | - | - | - | - | - | seed 2 refused |"; continue; }
    [ -z "$keep" ] || { cp "$tmp/j1.exr" "$keep/$name.exr"; cp "$tmp/j1.png" "$keep/$name.png" 2>/dev/null || true; }
    meas=$("$py" - "$tmp/j1.exr" "$tmp/j2.exr" <<'EOF'
import sys, numpy as np, OpenImageIO as oiio
def lum(p):
    b = oiio.ImageBuf(p); n = list(b.spec().channelnames)
    a = np.asarray(b.get_pixels(oiio.FLOAT), dtype=np.float64)
    return a[:, :, [n.index(c) for c in 'RGB']] @ np.array([0.2126, 0.7152, 0.0722])
y1, y2 = lum(sys.argv[1]), lum(sys.argv[2])
print(f'{np.sqrt(((y1 - y2) ** 2 / 2).mean()) / ((y1 + y2) / 2).mean():.4f}')
EOF
)
    awk -v n="$name" -v spp="${sppd:--}" -v c1="$c1" -v c2="$c2" -v est="${est:-}" -v m="$meas" -v b="$budget" 'BEGIN {
      c = (c1 + c2) / 2; k = sqrt(c / b)
      printf "| %s | %s | %.1f | %s | %.4f | %s | **%.4f** |\n", n, spp, c, est == "" ? "-" : est, m,
        est == "" ? "-" : sprintf("%.4f", est * k), m * k }'
  done
fi
echo
echo "load after: $(uptime)"
