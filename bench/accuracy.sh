#!/usr/bin/env bash
# Accuracy against time (docs/accuracy.md): the real error of `prismfarm render --direct` against a
# high-quality reference, as a function of CPU time, for each knob:
#   samples per pixel (every curve: 1, 4, 16, ... spp until a point would cost more than --cap),
#   spectral buckets (8, 16, 32, 45; the reference has 64), dispersion strategy (hero, fanout),
#   photon count and light-map density against the photon map (scenes/prism_beam.pbrt).
# Scenes: prism (dispersion seen through glass), crystal (gem fire), prism_beam (photon pass).
# References: two independent halves (seeds 900001, 900002), hero sampling, 64 buckets, many
# spp; cached in ${XDG_CACHE_HOME:-~/.cache}/prismfarm/accuracy by a hash of the scene, its
# settings and the binary, so a second run reuses them. Errors are measured on the linear sRGB
# channels by bench_accuracy_diff (relative RMSE of luminance, and a colour error), and the
# reference's own noise (measured from its two halves) is subtracted in quadrature.
# Also checks the job's own error estimate (the EXR's rel_rmse, --target-error) against it.
# Writes docs/accuracy/*.png (gnuplot) and the part of docs/accuracy.md between its
# "accuracy:begin" and "accuracy:end" markers.
#
# usage: bash bench/accuracy.sh [--quick] [--reps N] [--res WxH] [--cap S] [--ref-spp N]
#                               [--build DIR] [--no-build] [--any-binary] [--no-docs]
#   --quick       about a minute at 48x36, small references and a subset of the settings, to
#                 check that the script works (implies --no-docs)
#   --reps N      renders per point, with different seeds (default 1): errors are averaged as
#                 squares, times by their median
#   --res WxH     image size (default 96x72); --cap S: CPU seconds a point may cost (default 48)
#   --ref-spp N   spp of each half of a reference (default 8192)
#   --build DIR   Release build folder (default build-bench in the repository); built first
#   --no-build    use DIR's prismfarm and bench_accuracy_diff as they are
#   --any-binary  reuse cached references made by another build of the same version
#   --no-docs     leave the tables and plots in a folder under /tmp (printed at the end)
# The full run took 33 minutes the first time (references: 17 CPU-minutes) on 2 cores shared
# with other builds (load average 4 to 8), 12 minutes with the references cached.
set -euo pipefail
export LC_ALL=C

ROOT=$(cd "$(dirname "$0")/.." && pwd)
REPS=1
RES=96x72
CAP=48
REF_SPP=8192
BUILD=$ROOT/build-bench
DO_BUILD=1
WRITE_DOCS=1
QUICK=0
ANY_BINARY=0
RES_SET=0 CAP_SET=0 REF_SET=0
while (($#)); do
  case $1 in
    --quick) QUICK=1; shift ;;
    --reps) REPS=${2:-}; shift 2 ;;
    --res) RES=${2:-}; RES_SET=1; shift 2 ;;
    --cap) CAP=${2:-}; CAP_SET=1; shift 2 ;;
    --ref-spp) REF_SPP=${2:-}; REF_SET=1; shift 2 ;;
    --build) BUILD=${2:-}; shift 2 ;;
    --no-build) DO_BUILD=0; shift ;;
    --any-binary) ANY_BINARY=1; shift ;;
    --no-docs) WRITE_DOCS=0; shift ;;
    -h|--help) sed -n '2,30p' "$0"; exit 0 ;;
    *) echo "bench/accuracy.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
if ((QUICK)); then
  ((RES_SET)) || RES=48x36
  ((CAP_SET)) || CAP=1.5
  ((REF_SET)) || REF_SPP=512
  WRITE_DOCS=0
fi
die() { echo "bench/accuracy.sh: $*" >&2; exit 1; }
[[ $REPS =~ ^[1-9][0-9]*$ ]] || die "--reps expects a positive integer"
[[ $REF_SPP =~ ^[1-9][0-9]*$ ]] || die "--ref-spp expects a positive integer"
[[ $RES =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || die "--res expects WxH"
[[ $CAP =~ ^[0-9]+(\.[0-9]+)?$ ]] || die "--cap expects seconds"
command -v gnuplot >/dev/null || die "needs gnuplot (Debian package gnuplot-nox; deploy/install-deps.sh)"
command -v sha256sum >/dev/null || die "needs sha256sum (coreutils)"

if ((DO_BUILD)); then
  echo "== building Release into $BUILD" >&2
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" -j"$(nproc)" --target prismfarm bench_accuracy_diff >/dev/null
fi
BIN=$BUILD/cli/prismfarm
DIFF=$BUILD/bench/bench_accuracy_diff
[[ -x $BIN && -x $DIFF ]] || die "no $BIN or $DIFF (build them, or drop --no-build)"

WORK=$(mktemp -d /tmp/prismfarm-accuracy-XXXXXX)
if ((WRITE_DOCS)); then
  trap 'rm -rf "$WORK"' EXIT
  OUT=$ROOT/docs/accuracy
else
  OUT=$WORK/out
fi
mkdir -p "$WORK/scn" "$WORK/img" "$WORK/log" "$WORK/plot" "$OUT"
cp -r "$ROOT/scenes/geometry" "$WORK/scn/"
CACHE=${XDG_CACHE_HOME:-$HOME/.cache}/prismfarm/accuracy
mkdir -p "$CACHE"
VERSION=$("$BIN" --version 2>&1 | head -1)
if ((ANY_BINARY)); then BIN_ID=any; else BIN_ID=$(sha256sum "$BIN" | cut -c1-16); fi
CPU_MODEL=$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')
LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
T_START=$EPOCHREALTIME

# ---------------------------------------------------------------- settings

# One line per setting: id, scene, buckets, dispersion, photons, store, light-map density,
# gather radius ("-": the scene's own), in --quick (1/0), label.
SETTINGS=$(cat <<'EOF'
p_h8     prism       8  hero   -       -         -    -      0 prism, hero, 8 buckets
p_h16    prism       16 hero   -       -         -    -      1 prism, hero, 16 buckets
p_h32    prism       32 hero   -       -         -    -      0 prism, hero, 32 buckets
p_h45    prism       45 hero   -       -         -    -      0 prism, hero, 45 buckets
p_h64    prism       64 hero   -       -         -    -      1 prism, hero, 64 buckets
p_f8     prism       8  fanout -       -         -    -      1 prism, fan-out, 8 buckets
p_f16    prism       16 fanout -       -         -    -      1 prism, fan-out, 16 buckets
p_f32    prism       32 fanout -       -         -    -      0 prism, fan-out, 32 buckets
p_f45    prism       45 fanout -       -         -    -      0 prism, fan-out, 45 buckets
c_h16    crystal     16 hero   -       -         -    -      1 crystal, hero, 16 buckets
c_f16    crystal     16 fanout -       -         -    -      1 crystal, fan-out, 16 buckets
b_pm1e5  prism_beam  16 hero   100000  photonmap -    -      1 prism_beam, photon map, 0.1 M photons
b_pm1e6  prism_beam  16 hero   1000000 photonmap -    -      0 prism_beam, photon map, 1 M photons
b_pm4e6  prism_beam  16 hero   4000000 photonmap -    -      0 prism_beam, photon map, 4 M photons
b_pm1e6f prism_beam  16 fanout 1000000 photonmap -    -      0 prism_beam, photon map, 1 M photons, fan-out
b_lm100  prism_beam  16 hero   1000000 lightmap  100  -      0 prism_beam, light map 100/m², 1 M photons
b_lm400  prism_beam  16 hero   1000000 lightmap  400  -      1 prism_beam, light map 400/m², 1 M photons
b_lm1600 prism_beam  16 hero   1000000 lightmap  1600 -      0 prism_beam, light map 1600/m², 1 M photons
EOF
)
if ((QUICK)); then SETTINGS=$(awk '$9 == 1' <<<"$SETTINGS"); fi
SCENES=(prism crystal prism_beam)
# The references: hero (continuous wavelengths, no dispersive aliasing), 64 buckets; the photon
# scene's with 16 times the photons and half the gather radius (a quarter of the area: 4 times
# the photons in a gather, so less noise, and less blur than any setting measured).
ref_spec() {
  case $1 in
    prism_beam) if ((QUICK)); then echo "64 hero 1000000 photonmap - 0.0075"
                else echo "64 hero 16000000 photonmap - 0.0075"; fi ;;
    *) echo "64 hero - - - -" ;;
  esac
}
field() { awk -v id="$1" -v f="$2" '$1 == id { print $f }' <<<"$SETTINGS"; }
label() { awk -v id="$1" '$1 == id { for (i = 10; i <= NF; i++) printf "%s%s", $i, i < NF ? " " : ""; print "" }' <<<"$SETTINGS"; }
have() { awk -v id="$1" '$1 == id { f = 1 } END { exit !f }' <<<"$SETTINGS"; }

# make_scene OUT SCENE BUCKETS PHOTONS STORE DENSITY RADIUS: a variant of scenes/SCENE.pbrt
# next to a copy of scenes/geometry (the scene's includes are relative to its folder).
make_scene() {
  local out=$1 src=$ROOT/scenes/$2.pbrt nb=$3 ph=$4 store=$5 dens=$6 rad=$7
  local args=(-E -e "s/\"integer nbuckets\" \[ *[0-9]+ *\]/\"integer nbuckets\" [ $nb ]/")
  local extra=""
  [[ $store != - ]] && extra+=" \"string store\" \"$store\""
  [[ $dens != - ]] && extra+=" \"float lightmapdensity\" [ $dens ]"
  [[ $ph != - ]] && args+=(-e "s/\"integer photons\" \[ *[0-9]+ *\]/\"integer photons\" [ $ph ]$extra/")
  [[ $rad != - ]] && args+=(-e "s/\"float radius\" \[ *[0-9.]+ *\]/\"float radius\" [ $rad ]/")
  sed "${args[@]}" "$src" >"$out"
  grep -q "\"integer nbuckets\" \[ $nb \]" "$out" || die "could not set nbuckets in $src"
  [[ $ph == - ]] || grep -q "\"integer photons\" \[ $ph \]" "$out" || die "could not set photons in $src"
  [[ $rad == - ]] || grep -q "\"float radius\" \[ $rad \]" "$out" || die "could not set radius in $src"
}

# run_timed LOG CMD...: runs CMD in this shell (so that `times` counts it among the shell's
# children: getrusage(RUSAGE_CHILDREN), both threads' CPU) and sets RUN_CPU (user + system
# seconds) and RUN_WALL. `times` must not run in a subshell, hence the redirections to files.
run_timed() {
  local log=$1; shift
  local w0=$EPOCHREALTIME
  times >"$WORK/times0"
  if ! "$@" >"$log" 2>&1; then
    cat "$log" >&2
    die "failed: $*"
  fi
  times >"$WORK/times1"
  local w1=$EPOCHREALTIME
  RUN_CPU=$(awk 'function s(t,  m) { m = t; sub(/m.*/, "", m); sub(/^[0-9]+m/, "", t); sub(/s$/, "", t); return 60 * m + t }
                 FNR == 2 { c[FILENAME] = s($1) + s($2) } END { printf "%.3f", c[ARGV[2]] - c[ARGV[1]] }' \
            "$WORK/times0" "$WORK/times1")
  RUN_WALL=$(awk -v a="$w0" -v b="$w1" 'BEGIN { printf "%.3f", b - a }')
}

# key=value figures of bench_accuracy_diff's line: kv LINE KEY
. "$ROOT/bench/diff_fields.sh"

# ---------------------------------------------------------------- references

echo "== references ($RES, 2 x $REF_SPP spp, hero, 64 buckets) in $CACHE" >&2
: >"$WORK/refs.tsv"
for scene in "${SCENES[@]}"; do
  if ! awk -v s="$scene" '$2 == s { f = 1 } END { exit !f }' <<<"$SETTINGS"; then continue; fi
  read -r nb disp ph store dens rad <<<"$(ref_spec "$scene")"
  make_scene "$WORK/scn/ref_$scene.pbrt" "$scene" "$nb" "$ph" "$store" "$dens" "$rad"
  key=$( { cat "$WORK/scn/ref_$scene.pbrt" "$ROOT"/scenes/geometry/*;
           echo "$RES $REF_SPP $disp $VERSION $BIN_ID"; } | sha256sum | cut -c1-20)
  dir=$CACHE/${scene}_$key
  cached=yes
  if [[ ! -s $dir/b.exr ]]; then
    cached=no
    mkdir -p "$dir"
    cpu=0
    for half in a b; do
      seed=$([[ $half == a ]] && echo 900001 || echo 900002)
      echo "   $scene: reference half $half, $REF_SPP spp" >&2
      run_timed "$WORK/log/ref_${scene}_$half.log" "$BIN" render "$WORK/scn/ref_$scene.pbrt" \
        --direct --quiet --res "$RES" --spp "$REF_SPP" --seed "$seed" --dispersion "$disp" \
        -o "$dir/$half.tmp.exr"
      mv "$dir/$half.tmp.exr" "$dir/$half.exr"
      rm -f "$dir/$half.tmp.png"
      cpu=$(awk -v a="$cpu" -v b="$RUN_CPU" 'BEGIN { print a + b }')
    done
    echo "cpu=$cpu" >"$dir/info"
  fi
  line=$("$DIFF" "$dir/a.exr" "$dir/a.exr" "$dir/b.exr")
  ests=$(kv "$line" ref_est)
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$scene" "$dir" "$(kv "$line" floor_lum)" \
    "$(kv "$line" floor_col)" "${ests%,*}" "${ests#*,}" "$(sed -n 's/^cpu=//p' "$dir/info")" \
    "$cached" "$ph $rad" >>"$WORK/refs.tsv"
  echo "   $scene: floor $(kv "$line" floor_lum) (luminance), $(kv "$line" floor_col) (colour); cached: $cached" >&2
done
ref_dir() { awk -v s="$1" '$1 == s { print $2 }' "$WORK/refs.tsv"; }

# ---------------------------------------------------------------- the sweeps

# Every point: spp = 1, 4, 16, ... (powers of 4: square and powers of two, so both pixel
# positions and wavelengths are stratified, as a user would pick them); the next point is
# rendered while its predicted CPU time, t_last + 3 (t_last - t_first), is within the cap.
# Seeds depend on the point and the repetition only, so every setting of a scene sees the same
# random numbers: hero renders that differ in their buckets alone follow the same paths.
: >"$WORK/runs.tsv"
for id in $(awk '{ print $1 }' <<<"$SETTINGS"); do
  scene=$(field "$id" 2)
  make_scene "$WORK/scn/$id.pbrt" "$scene" "$(field "$id" 3)" "$(field "$id" 5)" \
    "$(field "$id" 6)" "$(field "$id" 7)" "$(field "$id" 8)"
  rdir=$(ref_dir "$scene")
  echo "== $id: $(label "$id")" >&2
  spp=1 k=0 first=
  while :; do
    cpus=()
    for ((rep = 1; rep <= REPS; rep++)); do
      seed=$((1000 * rep + k))
      img=$WORK/img/${id}_${spp}_$rep.exr
      run_timed "$WORK/log/${id}_${spp}_$rep.log" "$BIN" render "$WORK/scn/$id.pbrt" --direct \
        --quiet --res "$RES" --spp "$spp" --seed "$seed" --dispersion "$(field "$id" 4)" -o "$img"
      rm -f "${img%.exr}.png"
      nonfinite=$(sed -n 's/.*; \([0-9]*\) non-finite samples discarded.*/\1/p' \
        "$WORK/log/${id}_${spp}_$rep.log" | tail -1)
      line=$("$DIFF" "$img" "$rdir/a.exr" "$rdir/b.exr")
      printf '%s\t%d\t%d\t%d\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$id" "$spp" "$rep" \
        "$seed" "$RUN_CPU" "$RUN_WALL" "$(kv "$line" lum)" "$(kv "$line" col)" \
        "$(kv "$line" y_ratio)" "$(kv "$line" r_ratio)" "$(kv "$line" g_ratio)" \
        "$(kv "$line" b_ratio)" "$(kv "$line" est)" "${nonfinite:--}" >>"$WORK/runs.tsv"
      cpus+=("$RUN_CPU")
    done
    last=$(printf '%s\n' "${cpus[@]}" | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }')
    first=${first:-$last}
    printf '   %6d spp  %8.2f CPU s  luminance %s  colour %s\n' "$spp" "$last" \
      "$(kv "$line" lum)" "$(kv "$line" col)" >&2
    awk -v a="$first" -v b="$last" -v c="$CAP" 'BEGIN { exit !(b + 3 * (b - a) <= c) }' || break
    ((spp < 65536)) || break
    spp=$((spp * 4)) k=$((k + 1))
  done
done

# ---------------------------------------------------------------- the job's own estimate

# --target-error on the scenes' own settings (16 buckets, hero, 1 M photons), with the cap as
# a time limit: where does the job stop, and how far is it then really?
: >"$WORK/targets.tsv"
TARGETS=(0.2 0.1 0.05)
TLIM=$(awk -v c="$CAP" 'BEGIN { printf "%d", c == int(c) ? c : int(c) + 1 }')
((QUICK)) && TARGETS=(0.5)
for id in p_h16 c_h16 b_pm1e6 b_pm1e5; do
  have "$id" || continue
  scene=$(field "$id" 2)
  [[ $scene == prism_beam && $id == b_pm1e5 ]] && have b_pm1e6 && continue
  rdir=$(ref_dir "$scene")
  for tgt in "${TARGETS[@]}"; do
    echo "== $id: --target-error $tgt --time-limit ${TLIM}s" >&2
    img=$WORK/img/${id}_target_$tgt.exr
    run_timed "$WORK/log/${id}_target_$tgt.log" "$BIN" render "$WORK/scn/$id.pbrt" --direct \
      --quiet --res "$RES" --spp 65536 --seed 77 --dispersion "$(field "$id" 4)" \
      --target-error "$tgt" --time-limit "$TLIM" -o "$img"
    rm -f "${img%.exr}.png"
    line=$("$DIFF" "$img" "$rdir/a.exr" "$rdir/b.exr")
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$id" "$tgt" "$(kv "$line" spp)" "$(kv "$line" stop)" \
      "$(kv "$line" est)" "$(kv "$line" lum)" "$RUN_CPU" "$RUN_WALL" >>"$WORK/targets.tsv"
  done
done

# ---------------------------------------------------------------- bucket bias, same paths

# Hero renders with N and 64 buckets at the same point and seed follow the same paths: their
# difference is the discretisation alone (the same samples binned and weighted differently),
# plus a little noise of that difference that falls with spp.
: >"$WORK/binning.tsv"
if have p_h64; then
  for id in p_h8 p_h16 p_h32 p_h45; do
    have "$id" || continue
    for img in "$WORK"/img/"${id}"_*_1.exr; do
      spp=${img#"$WORK/img/${id}_"}; spp=${spp%_1.exr}
      [[ $spp =~ ^[0-9]+$ && -f $WORK/img/p_h64_${spp}_1.exr ]] || continue
      line=$("$DIFF" "$img" "$WORK/img/p_h64_${spp}_1.exr")
      printf '%s\t%s\t%s\t%s\n' "$id" "$spp" "$(kv "$line" lum)" "$(kv "$line" col)" >>"$WORK/binning.tsv"
    done
  done
  sort -t$'\t' -k1,1 -k2,2n -o "$WORK/binning.tsv" "$WORK/binning.tsv"
fi

LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)
ELAPSED=$(awk -v a="$T_START" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.0f", b - a }')

# ---------------------------------------------------------------- analysis

# Per point (setting, spp): mean square error over the repetitions, minus the reference's own
# noise squared (floor), median times. Per setting, a weighted least-squares fit of
#   MSE(n) = b^2 + v / n        (weights 1 / MSE^2: every point counts relatively alike)
#   CPU(n) = t0 + c n           (weights 1 / CPU^2; t0 the photon pass and loading)
# gives the plateau b (bias: discretisation, blur, the reference's own bias) and the noise
# constant v c = MSE x camera CPU seconds, whose inverse is the efficiency of the setting.
# A plateau is kept only when b^2 is at least half the last point's mean square error.
awk -F'\t' -v OFS='\t' '
  FILENAME == ARGV[1] { fl[$1] = $3; fc[$1] = $4; next }
  FILENAME == ARGV[2] { split($0, w, " +"); scene[w[1]] = w[2]; next }
  { key = $1 SUBSEP $2
    if (!(key in n)) { order[++np] = key }
    n[key]++; sl[key] += $7 * $7; sc[key] += $8 * $8; cpu[key, n[key]] = $5; wall[key, n[key]] = $6
    yr[key] += $9; rr[key] += $10; gr[key] += $11; br[key] += $12
    if ($13 != "-") { es[key] += $13; ne[key]++ }
    nf[key] += ($14 == "-" ? 0 : $14) }
  function median(a, key, m,   i, j, t, v) {
    for (i = 1; i <= m; i++) v[i] = a[key, i]
    for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
    return m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2 }
  END {
    for (i = 1; i <= np; i++) {
      key = order[i]; split(key, k, SUBSEP); s = scene[k[1]]; m = n[key]
      ml = sl[key] / m; mc = sc[key] / m
      cl = ml - fl[s] * fl[s]; cc = mc - fc[s] * fc[s]
      print k[1], k[2], median(cpu, key, m), median(wall, key, m), sqrt(ml), sqrt(mc),
            (cl > 0 ? sqrt(cl) : 0), (cc > 0 ? sqrt(cc) : 0),
            (ne[key] ? es[key] / ne[key] : "-"), yr[key] / m, rr[key] / m, gr[key] / m, br[key] / m, nf[key], m
    } }' "$WORK/refs.tsv" <(echo "$SETTINGS") "$WORK/runs.tsv" >"$WORK/points.tsv"
# points.tsv: id spp cpu wall lum_raw col_raw lum col est y_ratio r g b nonfinite reps

awk -F'\t' -v OFS='\t' '
  function fit(id, col,   i, S, Sx, Sy, Sxx, Sxy, x, y, w, d, a, v) {
    S = Sx = Sy = Sxx = Sxy = 0
    for (i = 1; i <= cnt[id]; i++) {
      if (raw[id, i, col] <= 0) continue
      x = 1 / spp[id, i]; y = val[id, i, col]; w = 1 / (raw[id, i, col] ^ 2)
      S += w; Sx += w * x; Sy += w * y; Sxx += w * x * x; Sxy += w * x * y }
    d = S * Sxx - Sx * Sx
    if (cnt[id] >= 3 && d > 0) { a = (Sxx * Sy - Sx * Sxy) / d; v = (S * Sxy - Sx * Sy) / d }
    else a = -1
    # A plateau counts only where the curve visibly flattens: b^2 at least half the mean square
    # error of the last point. Below that the points cannot tell it from their own scatter.
    if (a < 0.5 * val[id, cnt[id], col]) { a = 0; v = Sxy / Sxx }
    if (v < 0) v = 0
    FA = a; FV = v }
  { id = $1; i = ++cnt[id]; if (i == 1) ids[++nid] = id
    spp[id, i] = $2; t[id, i] = $3
    val[id, i, 1] = $7 * $7; val[id, i, 2] = $8 * $8; raw[id, i, 1] = $5 * $5; raw[id, i, 2] = $6 * $6 }
  END {
    for (j = 1; j <= nid; j++) {
      id = ids[j]
      S = Sx = Sy = Sxx = Sxy = 0
      for (i = 1; i <= cnt[id]; i++) {
        w = 1 / (t[id, i] ^ 2); x = spp[id, i]; y = t[id, i]
        S += w; Sx += w * x; Sy += w * y; Sxx += w * x * x; Sxy += w * x * y }
      d = S * Sxx - Sx * Sx
      if (cnt[id] >= 2 && d > 0) { t0 = (Sxx * Sy - Sx * Sxy) / d; c = (S * Sxy - Sx * Sy) / d }
      else { t0 = 0; c = t[id, 1] / spp[id, 1] }
      if (t0 < 0) { t0 = 0; c = Sxy / Sxx }
      fit(id, 1); bl = FA; vl = FV
      fit(id, 2); bc = FA; vc = FV
      print id, sqrt(bl), vl, sqrt(bc), vc, t0, c
    } }' "$WORK/points.tsv" >"$WORK/fits.tsv"
# fits.tsv: id b_lum v_lum b_col v_col t0 c

# ---------------------------------------------------------------- plots

# plot FILE TITLE ENTRY...; ENTRY = id|colour|dashtype|title. Two panels: luminance, colour.
plot() {
  local file=$1 title=$2; shift 2
  local p=() e id col dt tt
  for e in "$@"; do
    IFS='|' read -r id col dt tt <<<"$e"
    have "$id" || continue
    awk -F'\t' -v id="$id" '$1 == id { print $3, 100 * $7, 100 * $8, $2 }' "$WORK/points.tsv" >"$WORK/plot/$id.dat"
    p+=("'$WORK/plot/$id.dat' using 1:(column(COL) > 0 ? column(COL) : NaN) with linespoints lw 2 pt 7 ps 0.8 lc rgb '$col' dt $dt title '$tt'")
  done
  ((${#p[@]})) || return 0
  local plots
  plots=$(IFS=,; echo "${p[*]}")
  gnuplot <<EOF
set terminal pngcairo size 1500,620 font "DejaVu Sans,11" noenhanced
set output '$file'
set multiplot layout 1,2 title "$title ($RES, --direct; reference noise subtracted)" font "DejaVu Sans,13"
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set xlabel "CPU time (s, user + system of every thread)"
set format x "%g"
set format y "%g"
set key bottom left font "DejaVu Sans,9" box opaque
set yrange [0.5:*]
set arrow 1 from graph 0, first 5 to graph 1, first 5 nohead dt 3 lc rgb 'gray40' back
set arrow 2 from graph 0, first 2 to graph 1, first 2 nohead dt 3 lc rgb 'gray40' back
set arrow 3 from graph 0, first 1 to graph 1, first 1 nohead dt 3 lc rgb 'gray40' back
set label 1 "5 %" at graph 0.99, first 5 right offset 0,0.6 tc rgb 'gray40'
set label 2 "2 %" at graph 0.99, first 2 right offset 0,0.6 tc rgb 'gray40'
set label 3 "1 %" at graph 0.99, first 1 right offset 0,0.6 tc rgb 'gray40'
set ylabel "relative RMSE of luminance (%)"
set title "luminance"
COL = 2
plot $plots
set ylabel "relative colour error (%)"
set title "colour (chromaticity error weighted by luminance)"
COL = 3
plot $plots
unset multiplot
EOF
}

plot "$OUT/dispersion.png" "Dispersion strategy: hero against fan-out, 16 buckets" \
  "p_h16|#1f77b4|2|prism, hero" "p_f16|#1f77b4|1|prism, fan-out" \
  "c_h16|#d62728|2|crystal, hero" "c_f16|#d62728|1|crystal, fan-out" \
  "b_pm1e6|#2ca02c|2|prism_beam (1 M photons), hero" "b_pm1e6f|#2ca02c|1|prism_beam (1 M photons), fan-out"
plot "$OUT/buckets.png" "Spectral buckets on prism: hero (dashed) and fan-out (solid)" \
  "p_h8|#9467bd|2|hero, 8" "p_h16|#1f77b4|2|hero, 16" "p_h32|#2ca02c|2|hero, 32" "p_h45|#d62728|2|hero, 45" \
  "p_h64|#7f7f7f|2|hero, 64 (as the reference)" \
  "p_f8|#9467bd|1|fan-out, 8" "p_f16|#1f77b4|1|fan-out, 16" "p_f32|#2ca02c|1|fan-out, 32" "p_f45|#d62728|1|fan-out, 45"
plot "$OUT/photons.png" "Photon count and store on prism_beam (hero, 16 buckets)" \
  "b_pm1e5|#aec7e8|1|photon map, 0.1 M photons" "b_pm1e6|#1f77b4|1|photon map, 1 M" \
  "b_pm4e6|#08306b|1|photon map, 4 M" \
  "b_lm100|#fdae6b|2|light map 100 texels/m², 1 M" "b_lm400|#e6550d|2|light map 400/m², 1 M" \
  "b_lm1600|#7f2704|2|light map 1600/m², 1 M"
# The job's own estimate against the measured error, every point of every setting.
EST_PLOTS=()
for scene in "${SCENES[@]}"; do
  awk -F'\t' -v s="$scene" 'FILENAME == ARGV[1] { split($0, w, " +"); sc[w[1]] = w[2]; next }
    sc[$1] == s && $9 != "-" && $7 > 0 { print 100 * $7, 100 * $9 }' \
    <(echo "$SETTINGS") "$WORK/points.tsv" >"$WORK/plot/est_$scene.dat"
  [[ -s $WORK/plot/est_$scene.dat ]] || continue
  case $scene in prism) c='#1f77b4' ;; crystal) c='#d62728' ;; *) c='#2ca02c' ;; esac
  EST_PLOTS+=("'$WORK/plot/est_$scene.dat' using 1:2 with points pt 7 ps 0.9 lc rgb '$c' title '$scene'")
done
if ((${#EST_PLOTS[@]})); then
  gnuplot <<EOF
set terminal pngcairo size 720,620 font "DejaVu Sans,11" noenhanced
set output '$OUT/estimate.png'
set title "The job's own estimate (EXR rel_rmse) against the measured error,\\nevery point of every setting"
set logscale xy
set grid lc rgb '#dddddd'
set xlabel "measured relative RMSE of luminance (%)"
set ylabel "estimate (%)"
set format x "%g"
set format y "%g"
set key top left
plot $(IFS=,; echo "${EST_PLOTS[*]}"), x with lines dt 2 lc rgb 'gray30' title 'estimate = measured'
EOF
fi

# ---------------------------------------------------------------- the report

pct() { awk -v v="$1" 'BEGIN { if (v == "-" || v == "") print "-"; else if (v * 100 < 0.095) printf "%.2f %%", v * 100; else if (v * 100 < 9.95) printf "%.1f %%", v * 100; else printf "%.0f %%", v * 100 }'; }
{
  NP=$(wc -l <"$WORK/runs.tsv")
  echo "Generated by \`bash bench/accuracy.sh$( ((REPS != 1)) && echo " --reps $REPS")\` on $(date -u +%Y-%m-%d): $CPU_MODEL, $(nproc) cores"
  echo "shared with other jobs (load average $LOAD_BEFORE before, $LOAD_AFTER after); $NP renders"
  echo "in $ELAPSED s of wall-clock time. $VERSION, \`render --direct\` (plain threads, all cores), $RES,"
  echo "$REPS render(s) per point, a point rendered while its predicted CPU time is within $CAP s."
  echo
  echo "**References** (hero, 64 buckets, two halves of $REF_SPP spp each with seeds 900001 and 900002;"
  echo "their mean is the reference). *Floor*: the reference's own noise, the error of a half"
  echo "against the mean (= that of the mean, bench_accuracy_diff.c); it is subtracted in quadrature"
  echo "from every measured error below. *Estimate*: the halves' own rel_rmse over √2."
  echo
  echo "| scene | photons, radius | CPU s | floor, luminance | floor, colour | estimate, luminance | cached |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  while IFS=$'\t' read -r s d flum fcol ea eb cpu cached phr; do
    est=$(awk -v a="$ea" -v b="$eb" 'BEGIN { printf "%.4g", sqrt(a * a + b * b) / 2 }')
    printf '| `%s` | %s | %.0f | %s | %s | %s | %s |\n' "$s" "$( [[ $phr == "- -" ]] && echo "-" || echo "$phr")" \
      "$cpu" "$(pct "$flum")" "$(pct "$fcol")" "$(pct "$est")" "$cached"
  done <"$WORK/refs.tsv"
  echo
  echo "**Every setting.** *Last*: the point with the most spp. *Plateau*: b of the fit"
  echo "MSE(n) = b² + v/n over the points (weights 1/MSE²): the error that no spp removes"
  echo "(discretisation, blur, a bias of the renderer or of the reference beyond its noise), kept"
  echo "only where the curve visibly flattens (b² at least half the last point's MSE), else –. *Noise × time*: v·c, the mean square error times the CPU seconds of the"
  echo "camera pass (c: CPU seconds per spp from CPU(n) = t0 + c·n; t0 is loading and the photon"
  echo "pass) — the smaller, the faster the noise goes. *Energy*: mean Y, R, G, B of the last point"
  echo "over the reference's (a colour cast or lost energy shows here)."
  echo
  echo "| setting | last spp | CPU s | luminance | colour | plateau lum. | plateau col. | noise × time, lum. | noise × time, col. | t0 s | energy Y (R, G, B) | non-finite |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  awk -F'\t' 'FILENAME == ARGV[1] { f[$1] = $0; next }
    FILENAME == ARGV[2] { lab[$1] = $2; order[++no] = $1; next }
    { last[$1] = $0; nf[$1] += $14 }
    END { for (i = 1; i <= no; i++) { id = order[i]; if (!(id in last)) continue
      split(last[id], p, "\t"); split(f[id], q, "\t")
      printf "| %s | %d | %.3g | %s | %s | %s | %s | %.3g | %.3g | %.2f | %.3f (%.3f, %.3f, %.3f) | %d |\n",
        lab[id], p[2], p[3], pc(p[7]), pc(p[8]), (q[2] > 0 ? pc(q[2]) : "–"), (q[4] > 0 ? pc(q[4]) : "–"), q[3] * q[7], q[5] * q[7], q[6],
        p[10], p[11], p[12], p[13], nf[id] } }
    function pc(v) { v *= 100; return v < 0.095 ? sprintf("%.2f %%", v) : v < 9.95 ? sprintf("%.1f %%", v) : sprintf("%.0f %%", v) }' \
    "$WORK/fits.tsv" <(awk '{ l = ""; for (i = 10; i <= NF; i++) l = l (i > 10 ? " " : "") $i; print $1 "\t" l }' <<<"$SETTINGS") \
    "$WORK/points.tsv"
  echo
  echo "**CPU seconds to reach 5 %, 2 % and 1 %** relative error: interpolated on the log-log curve"
  echo "between the measured points that bracket it; *(≈ t)* when no point reached it, extrapolated"
  echo "by the fits (t0 + c·v/(e² − b²)); *never* when the plateau b is at or above e."
  echo
  echo "| setting | lum. 5 % | lum. 2 % | lum. 1 % | colour 5 % | colour 2 % | colour 1 % |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  awk -F'\t' 'FILENAME == ARGV[1] { b[$1, 1] = $2; v[$1, 1] = $3; b[$1, 2] = $4; v[$1, 2] = $5; t0[$1] = $6; c[$1] = $7; next }
    FILENAME == ARGV[2] { lab[$1] = $2; order[++no] = $1; next }
    { n[$1]++; t[$1, n[$1]] = $3; e[$1, n[$1], 1] = $7; e[$1, n[$1], 2] = $8 }
    function fmt(s) { return s < 10 ? sprintf("%.2f", s) : s < 100 ? sprintf("%.1f", s) : sprintf("%.0f", s) }
    function reach(id, m, tgt,   i, x0, x1, y0, y1, nn) {
      for (i = 1; i <= n[id]; i++) if (e[id, i, m] > 0 && e[id, i, m] <= tgt) {
        if (i == 1) return "≤ " fmt(t[id, 1])
        if (e[id, i - 1, m] <= 0) return fmt(t[id, i])
        x0 = log(t[id, i - 1]); x1 = log(t[id, i]); y0 = log(e[id, i - 1, m]); y1 = log(e[id, i, m])
        return fmt(exp(x0 + (log(tgt) - y0) * (x1 - x0) / (y1 - y0))) }
      if (b[id, m] >= tgt) return "never"
      nn = v[id, m] / (tgt * tgt - b[id, m] * b[id, m])
      return "(≈ " fmt(t0[id] + c[id] * nn) ")" }
    END { for (i = 1; i <= no; i++) { id = order[i]; if (!(id in n)) continue
      printf "| %s | %s | %s | %s | %s | %s | %s |\n", lab[id], reach(id, 1, 0.05), reach(id, 1, 0.02),
        reach(id, 1, 0.01), reach(id, 2, 0.05), reach(id, 2, 0.02), reach(id, 2, 0.01) } }' \
    "$WORK/fits.tsv" <(awk '{ l = ""; for (i = 10; i <= NF; i++) l = l (i > 10 ? " " : "") $i; print $1 "\t" l }' <<<"$SETTINGS") \
    "$WORK/points.tsv"
  echo
  for f in dispersion buckets photons; do
    [[ -f $OUT/$f.png ]] && echo "![$f](accuracy/$f.png)" && echo
  done
  if [[ -s $WORK/binning.tsv ]]; then
    echo "**Bucket discretisation alone** (prism, hero): a render with N buckets against the render"
    echo "with 64 at the same spp and seed. Hero wavelengths are continuous and drawn alike whatever"
    echo "the buckets, so both follow the same paths: the difference is the binning (a sample's colour"
    echo "becomes its bucket's), plus a noise of that difference that falls with spp; where it stops"
    echo "falling it is the discretisation bias. Luminance / colour:"
    echo
    sp=$(cut -f2 "$WORK/binning.tsv" | sort -n -u | tr '\n' ' ')
    printf '| buckets |'; for s in $sp; do printf ' %s spp |' "$s"; done; echo ' plateau (fit) |'
    printf '| --- |'; for s in $sp; do printf ' --- |'; done; echo ' --- |'
    for id in p_h8 p_h16 p_h32 p_h45; do
      grep -q "^$id	" "$WORK/binning.tsv" || continue
      printf '| %s |' "${id#p_h}"
      for s in $sp; do
        awk -F'\t' -v id="$id" -v s="$s" '$1 == id && $2 == s { printf " %.2f / %.2f %% |", 100 * $3, 100 * $4; f = 1 }
          END { if (!f) printf " - |" }' "$WORK/binning.tsv"
      done
      # d^2(n) = B^2 + V / n, weights 1 / d^2, with the plateau rule of the fits above.
      awk -F'\t' -v id="$id" '$1 == id && $3 > 0 { n++; x[n] = 1 / $2; y[n, 1] = $3 * $3; y[n, 2] = $4 * $4 }
        function b(c,   i, S, Sx, Sy, Sxx, Sxy, w, d, a) {
          S = Sx = Sy = Sxx = Sxy = 0
          for (i = 1; i <= n; i++) { w = 1 / y[i, c] ^ 2; S += w; Sx += w * x[i]; Sy += w * y[i, c]
            Sxx += w * x[i] ^ 2; Sxy += w * x[i] * y[i, c] }
          d = S * Sxx - Sx * Sx; a = n >= 3 && d > 0 ? (Sxx * Sy - Sx * Sxy) / d : 0
          return a >= 0.5 * y[n, c] ? sprintf("%.2f", 100 * sqrt(a)) : "–" }
        END { printf " %s / %s %% |\n", b(1), b(2) }' "$WORK/binning.tsv"
    done
    echo
  fi
  echo "**The job's own estimate** (the EXR's \`rel_rmse\`, the figure \`--target-error\` compares) against"
  echo "the measured relative RMSE of luminance, per setting: the ratio estimate / measured over its"
  echo "points with an estimate (from 4 spp; median, lowest, highest)."
  echo
  echo "| setting | points | median | lowest | highest |"
  echo "| --- | --- | --- | --- | --- |"
  awk -F'\t' 'FILENAME == ARGV[1] { lab[$1] = $2; order[++no] = $1; next }
    $9 != "-" && $7 > 0 { r[$1, ++n[$1]] = $9 / $7 }
    END { for (i = 1; i <= no; i++) { id = order[i]; m = n[id]; if (!m) continue
      for (a = 1; a <= m; a++) v[a] = r[id, a]
      for (a = 1; a <= m; a++) for (bb = a + 1; bb <= m; bb++) if (v[bb] < v[a]) { t = v[a]; v[a] = v[bb]; v[bb] = t }
      printf "| %s | %d | %.2f | %.2f | %.2f |\n", lab[id], m, m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2, v[1], v[m] } }' \
    <(awk '{ l = ""; for (i = 10; i <= NF; i++) l = l (i > 10 ? " " : "") $i; print $1 "\t" l }' <<<"$SETTINGS") \
    "$WORK/points.tsv"
  echo
  [[ -f $OUT/estimate.png ]] && echo "![estimate against measured](accuracy/estimate.png)" && echo
  if [[ -s $WORK/targets.tsv ]]; then
    echo "**\`--target-error\`** on the scenes' own settings (16 buckets, hero), with \`--time-limit ${TLIM}s\`"
    echo "(wall-clock) as a guard: where the job stopped, its estimate there and the measured error."
    echo
    echo "| setting | target | stopped at | why | estimate | measured | CPU s |"
    echo "| --- | --- | --- | --- | --- | --- | --- |"
    while IFS=$'\t' read -r id tgt spp stop est lum cpu wall; do
      printf '| %s | %s | %s spp | %s | %s | %s | %.1f |\n' "$(label "$id")" "$(pct "$tgt")" "$spp" "$stop" \
        "$(pct "$est")" "$(pct "$lum")" "$cpu"
    done <"$WORK/targets.tsv"
    echo
  fi
  echo "<details><summary>Every point (errors before and after the reference's noise is subtracted)</summary>"
  echo
  echo "| setting | spp | CPU s | wall s | luminance raw | colour raw | luminance | colour | estimate |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  awk -F'\t' '{ printf "| `%s` | %d | %.3f | %.3f | %.4f | %.4f | %.4f | %.4f | %s |\n", $1, $2, $3, $4, $5, $6, $7, $8, $9 }' "$WORK/points.tsv"
  echo
  echo "</details>"
} >"$WORK/report.md"

cat "$WORK/report.md"

if ((WRITE_DOCS)); then
  DOC=$ROOT/docs/accuracy.md
  if ! grep -q '<!-- accuracy:begin -->' "$DOC" 2>/dev/null; then
    printf '\n<!-- accuracy:begin -->\n<!-- accuracy:end -->\n' >>"$DOC"
  fi
  awk -v rep="$WORK/report.md" '
    /<!-- accuracy:begin -->/ { print; while ((getline l < rep) > 0) print l; skip = 1; next }
    /<!-- accuracy:end -->/ { skip = 0 }
    !skip' "$DOC" >"$WORK/doc.md"
  cp "$WORK/doc.md" "$DOC"
  echo "== wrote the tables into $DOC and the plots into $OUT" >&2
else
  cp "$WORK/report.md" "$WORK"/*.tsv "$OUT/"
  echo "== the report, data and plots are in $OUT" >&2
fi
