#!/usr/bin/env bash
# Spectral MIS against pbrt-v4's termination at a rough dispersive dielectric (docs/accuracy.md,
# "Spectral MIS at rough dispersive glass"): which of the two ways of carrying the 4 hero
# wavelengths through frosted glass gives less colour noise per CPU second.
#   mis   Integrator "bool spectralmis" true (the default): one lane's lobe is sampled, every
#         lane keeps the weight f / mean of the lanes' pdfs;
#   term  "bool spectralmis" false: the 3 secondary lanes end at the dispersive rough interface
#         and the hero carries 4 times its weight (pbrt-v4).
# Scene: bench/frosted_prism.pbrt (scenes/prism.pbrt with an N-SF11 prism of roughness 0.002).
# Reference: two independent halves (seeds 900001, 900002) with spectral MIS and --ref-spp spp
# each; their mean is the reference, and its own noise (a half against the mean, as in
# bench/accuracy.sh) is subtracted in quadrature from every error. Both strategies are unbiased,
# so either could make the reference; the energy ratios in the table check that they agree.
# Then, side by side (mis and term alternate at every point, with the same seeds), spp = 4, 16,
# 64, 256 while a point's predicted CPU time is within --cap: CPU time (user + system of the
# render, bash `times`) and the error against the reference (bench_accuracy_diff: relative RMSE
# of luminance and the colour error), averaged as squares over --reps renders with other seeds.
# The ratio: the CPU time term needs to reach the colour error that mis reaches, interpolated on
# the log-log curves, over the range both curves cover.
# Writes docs/accuracy/spectral_mis.png (gnuplot, if installed) and the part of docs/accuracy.md
# between its "spectral_mis:begin" and "spectral_mis:end" markers (appended at the end if absent).
#
# usage: bash bench/spectral_mis.sh [--bin PATH] [--diff PATH] [--res WxH] [--ref-spp N]
#                                   [--reps N] [--cap S] [--no-docs]
#   --bin PATH    prismfarm binary (default build/cli/prismfarm; built with deploy/build.sh
#                 release only if it does not exist)
#   --diff PATH   bench_accuracy_diff (default next to the binary: ../bench/bench_accuracy_diff)
#   --res WxH     image size (default 96x72)
#   --ref-spp N   spp of each half of the reference (default 2048)
#   --reps N      renders per point, other seeds (default 2)
#   --cap S       CPU seconds a point may cost (default 30)
#   --no-docs     leave the report, data and plot in a folder under /tmp (printed at the end)
set -euo pipefail
export LC_ALL=C

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BIN=$ROOT/build/cli/prismfarm
DIFF=
RES=96x72
REF_SPP=2048
REPS=2
CAP=30
WRITE_DOCS=1
ARGS="$*"
while (($#)); do
  case $1 in
    --bin) BIN=${2:-}; shift 2 ;;
    --diff) DIFF=${2:-}; shift 2 ;;
    --res) RES=${2:-}; shift 2 ;;
    --ref-spp) REF_SPP=${2:-}; shift 2 ;;
    --reps) REPS=${2:-}; shift 2 ;;
    --cap) CAP=${2:-}; shift 2 ;;
    --no-docs) WRITE_DOCS=0; shift ;;
    -h|--help) sed -n '2,31p' "$0"; exit 0 ;;
    *) echo "bench/spectral_mis.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
die() { echo "bench/spectral_mis.sh: $*" >&2; exit 1; }
[[ $REPS =~ ^[1-9][0-9]*$ ]] || die "--reps expects a positive integer"
[[ $REF_SPP =~ ^[1-9][0-9]*$ ]] || die "--ref-spp expects a positive integer"
[[ $RES =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || die "--res expects WxH"
[[ $CAP =~ ^[0-9]+(\.[0-9]+)?$ ]] || die "--cap expects seconds"

if [[ ! -x $BIN ]]; then
  [[ $BIN == "$ROOT/build/cli/prismfarm" ]] || die "no binary $BIN"
  echo "== no $BIN: building it (deploy/build.sh release)" >&2
  bash "$ROOT/deploy/build.sh" release >&2
fi
DIFF=${DIFF:-$(dirname "$BIN")/../bench/bench_accuracy_diff}
[[ -x $BIN ]] || die "no binary $BIN"
[[ -x $DIFF ]] || die "no $DIFF (build the bench_accuracy_diff target, or pass --diff)"
SCENE=$ROOT/bench/frosted_prism.pbrt
[[ -f $SCENE ]] || die "no $SCENE"

WORK=$(mktemp -d /tmp/prismfarm-spectral-mis-XXXXXX)
if ((WRITE_DOCS)); then
  trap 'rm -rf "$WORK"' EXIT
  OUT=$ROOT/docs/accuracy
else
  OUT=$WORK/out
fi
mkdir -p "$WORK/bench" "$WORK/img" "$WORK/log" "$OUT"
# The scene includes ../scenes/geometry/*: the variants live in $WORK/bench next to a link.
ln -s "$ROOT/scenes" "$WORK/scenes"
for s in mis term; do
  v=$([[ $s == mis ]] && echo true || echo false)
  sed -E "s/\"bool spectralmis\" (true|false)/\"bool spectralmis\" $v/" "$SCENE" >"$WORK/bench/$s.pbrt"
  grep -q "\"bool spectralmis\" $v" "$WORK/bench/$s.pbrt" || die "could not set spectralmis in $SCENE"
done
VERSION=$("$BIN" --version 2>&1 | head -1)
CPU_MODEL=$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')
LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
T_START=$EPOCHREALTIME

# run_timed LOG CMD... (as in bench/accuracy.sh): runs CMD in this shell so that `times` counts
# it among the shell's children (both threads' CPU); sets RUN_CPU (user + system s), RUN_WALL.
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
. "$ROOT/bench/diff_fields.sh"
render() { # render LOG SCENE SPP SEED OUT
  run_timed "$1" "$BIN" render "$2" --direct --quiet --res "$RES" --spp "$3" --seed "$4" -o "$5"
  rm -f "${5%.exr}.png"
}

# ---------------------------------------------------------------- the reference

echo "== reference: $RES, 2 x $REF_SPP spp, spectral MIS" >&2
REF_CPU=0
for half in a b; do
  seed=$([[ $half == a ]] && echo 900001 || echo 900002)
  render "$WORK/log/ref_$half.log" "$WORK/bench/mis.pbrt" "$REF_SPP" "$seed" "$WORK/img/ref_$half.exr"
  REF_CPU=$(awk -v a="$REF_CPU" -v b="$RUN_CPU" 'BEGIN { print a + b }')
  echo "   half $half: $RUN_CPU CPU s, $RUN_WALL s wall" >&2
done
line=$("$DIFF" "$WORK/img/ref_a.exr" "$WORK/img/ref_a.exr" "$WORK/img/ref_b.exr")
FLOOR_LUM=$(kv "$line" floor_lum)
FLOOR_COL=$(kv "$line" floor_col)
echo "   floor (the reference's own noise): luminance $FLOOR_LUM, colour $FLOOR_COL" >&2

# ---------------------------------------------------------------- the sweeps, side by side

# runs.tsv: strategy spp rep seed cpu wall lum col y_ratio r_ratio g_ratio b_ratio
: >"$WORK/runs.tsv"
spp=4 k=0 first=
while :; do
  tmax=0
  for ((rep = 1; rep <= REPS; rep++)); do
    seed=$((1000 * rep + k))
    for s in mis term; do
      img=$WORK/img/${s}_${spp}_$rep.exr
      render "$WORK/log/${s}_${spp}_$rep.log" "$WORK/bench/$s.pbrt" "$spp" "$seed" "$img"
      line=$("$DIFF" "$img" "$WORK/img/ref_a.exr" "$WORK/img/ref_b.exr")
      printf '%s\t%d\t%d\t%d\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$s" "$spp" "$rep" "$seed" \
        "$RUN_CPU" "$RUN_WALL" "$(kv "$line" lum)" "$(kv "$line" col)" "$(kv "$line" y_ratio)" \
        "$(kv "$line" r_ratio)" "$(kv "$line" g_ratio)" "$(kv "$line" b_ratio)" >>"$WORK/runs.tsv"
      printf '   %-4s %4d spp rep %d  %7.3f CPU s  luminance %s  colour %s\n' "$s" "$spp" "$rep" \
        "$RUN_CPU" "$(kv "$line" lum)" "$(kv "$line" col)" >&2
      tmax=$(awk -v a="$tmax" -v b="$RUN_CPU" 'BEGIN { print (b > a ? b : a) }')
    done
  done
  first=${first:-$tmax}
  ((spp < 256)) || break
  awk -v a="$first" -v b="$tmax" -v c="$CAP" 'BEGIN { exit !(b + 3 * (b - a) <= c) }' || break
  spp=$((spp * 4)) k=$((k + 1))
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)
ELAPSED=$(awk -v a="$T_START" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.0f", b - a }')

# ---------------------------------------------------------------- analysis

# points.tsv: strategy spp cpu(median) wall(median) lum_raw col_raw lum col y r g b reps;
# lum and col with the reference's noise subtracted in quadrature (as bench/accuracy.sh does).
awk -F'\t' -v OFS='\t' -v fl="$FLOOR_LUM" -v fc="$FLOOR_COL" '
  { key = $1 SUBSEP $2
    if (!(key in n)) order[++np] = key
    n[key]++; sl[key] += $7 * $7; sc[key] += $8 * $8; cpu[key, n[key]] = $5; wall[key, n[key]] = $6
    yr[key] += $9; rr[key] += $10; gr[key] += $11; br[key] += $12 }
  function median(a, key, m,   i, j, t, v) {
    for (i = 1; i <= m; i++) v[i] = a[key, i]
    for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
    return m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2 }
  END { for (i = 1; i <= np; i++) { key = order[i]; split(key, k, SUBSEP); m = n[key]
    ml = sl[key] / m; mc = sc[key] / m; cl = ml - fl * fl; cc = mc - fc * fc
    print k[1], k[2], median(cpu, key, m), median(wall, key, m), sqrt(ml), sqrt(mc),
          (cl > 0 ? sqrt(cl) : 0), (cc > 0 ? sqrt(cc) : 0), yr[key] / m, rr[key] / m, gr[key] / m, br[key] / m, m } }' \
  "$WORK/runs.tsv" >"$WORK/points.tsv"

# ratio.tsv: target colour error, CPU s of mis, CPU s of term, term / mis. Targets: every
# measured colour error of either curve inside the range both cover; each curve's CPU time
# there interpolated linearly in log(error) against log(CPU s) between its bracketing points.
awk -F'\t' -v OFS='\t' '
  $8 > 0 { i = ++n[$1]; t[$1, i] = $3; e[$1, i] = $8 }
  function at(s, x,   i, x0, x1, y0, y1) {
    for (i = 1; i < n[s]; i++)
      if ((e[s, i] >= x && x >= e[s, i + 1]) || (e[s, i] <= x && x <= e[s, i + 1])) {
        if (e[s, i] == e[s, i + 1]) return t[s, i]
        x0 = log(e[s, i]); x1 = log(e[s, i + 1]); y0 = log(t[s, i]); y1 = log(t[s, i + 1])
        return exp(y0 + (log(x) - x0) * (y1 - y0) / (x1 - x0)) }
    return -1 }
  END { for (s in n) for (i = 1; i <= n[s]; i++) {
      x = e[s, i]; a = at("mis", x); b = at("term", x)
      if (a > 0 && b > 0 && !(x in seen)) { seen[x] = 1; print x, a, b, b / a } } }' \
  "$WORK/points.tsv" | sort -g -r >"$WORK/ratio.tsv"
if [[ -s $WORK/ratio.tsv ]]; then
  RATIO=$(awk -F'\t' '{ s += log($4); n++ } END { printf "%.2f", exp(s / n) }' "$WORK/ratio.tsv")
  RATIO_LO=$(cut -f4 "$WORK/ratio.tsv" | sort -g | head -1 | awk '{ printf "%.2f", $1 }')
  RATIO_HI=$(cut -f4 "$WORK/ratio.tsv" | sort -g | tail -1 | awk '{ printf "%.2f", $1 }')
else
  RATIO=- RATIO_LO=- RATIO_HI=-
fi
# nt.tsv: spp, error^2 x CPU s (noise x time: constant where the error falls as 1 / sqrt(CPU s),
# and the smaller the faster the noise goes) of colour for mis and term, their ratio, and the
# same for luminance. Where both are flat in spp, the ratio is the CPU-time ratio at equal error.
awk -F'\t' -v OFS='\t' '{ v[$1, $2, 1] = $8 * $8 * $3; v[$1, $2, 2] = $7 * $7 * $3; if ($1 == "mis") sp[++n] = $2 }
  END { for (i = 1; i <= n; i++) { s = sp[i]; if (!((("term") SUBSEP s SUBSEP 1) in v)) continue
    a = v["mis", s, 1]; b = v["term", s, 1]; c = v["mis", s, 2]; d = v["term", s, 2]
    print s, a, b, (a > 0 ? b / a : "-"), c, d, (c > 0 ? d / c : "-") } }' "$WORK/points.tsv" >"$WORK/nt.tsv"
NT_SPP=$(tail -1 "$WORK/nt.tsv" | cut -f1)
NT_RATIO=$(tail -1 "$WORK/nt.tsv" | awk -F'\t' '{ printf "%.1f", $4 }')
NT_LUM=$(tail -1 "$WORK/nt.tsv" | awk -F'\t' '{ printf "%.2f", $7 }')
echo "== time ratio term / mis at equal colour error: $RATIO (range $RATIO_LO .. $RATIO_HI); noise x time ratio at $NT_SPP spp: $NT_RATIO" >&2

# ---------------------------------------------------------------- the plot

PLOT=0
if command -v gnuplot >/dev/null; then
  for s in mis term; do awk -F'\t' -v s="$s" '$1 == s' "$WORK/points.tsv" >"$WORK/$s.dat"; done
  gnuplot <<EOF
set terminal pngcairo size 960,440 font "DejaVu Sans,10" noenhanced
set output '$OUT/spectral_mis.png'
set multiplot layout 1,2 title "Frosted N-SF11 prism (roughness 0.002), $RES: error against CPU seconds"
set logscale xy
set grid lc rgb '#dddddd'
set xlabel "CPU seconds (user + system)"
set format x "%g"
set format y "%g"
set key top right
set title "colour error (%)"
plot '$WORK/mis.dat' using 3:(100*\$8) with linespoints lw 2 pt 7 title 'spectral MIS (default)', \
     '$WORK/term.dat' using 3:(100*\$8) with linespoints lw 2 pt 5 title 'terminate secondaries (pbrt-v4)'
set title "relative RMSE of luminance (%)"
plot '$WORK/mis.dat' using 3:(100*\$7) with linespoints lw 2 pt 7 title 'spectral MIS (default)', \
     '$WORK/term.dat' using 3:(100*\$7) with linespoints lw 2 pt 5 title 'terminate secondaries (pbrt-v4)'
unset multiplot
EOF
  PLOT=1
else
  echo "== gnuplot is not installed: no plot (apt-get install gnuplot-nox, then run again)" >&2
fi

# ---------------------------------------------------------------- the report

pct() { awk -v v="$1" 'BEGIN { v *= 100; if (v < 0.095) printf "%.2f %%", v; else if (v < 9.95) printf "%.1f %%", v; else printf "%.0f %%", v }'; }
{
  echo "## Spectral MIS at rough dispersive glass"
  echo
  echo "Which way of carrying the 4 hero wavelengths through a rough dispersive dielectric gives"
  echo "less colour noise per CPU second: spectral MIS (\`Integrator ... \"bool spectralmis\" true\`, the"
  echo "default: one lane's lobe is sampled and every lane keeps f / the mean of the 4 lobes' pdfs) or"
  echo "pbrt-v4's termination of the 3 secondary lanes at the interface (\`\"bool spectralmis\" false\`)."
  echo "Scene: [bench/frosted_prism.pbrt](../bench/frosted_prism.pbrt), the prism box of"
  echo "\`scenes/prism.pbrt\` with an N-SF11 prism of \`\"float roughness\" [ 0.002 ]\` (GGX α ≈ 0.045):"
  echo "blurred colour fringes everywhere the walls are seen through the prism."
  echo
  echo "Generated by \`bash bench/spectral_mis.sh${ARGS:+ $ARGS}\` on $(date -u +%Y-%m-%d): $CPU_MODEL, $(nproc) cores"
  echo "**shared with other jobs** (load average $LOAD_BEFORE before, $LOAD_AFTER after), $ELAPSED s"
  echo "of wall-clock time; $VERSION, \`render --direct\`, $RES, $REPS render(s) per point (errors"
  echo "averaged as squares, CPU times by their median), the two strategies alternating at every point"
  echo "with the same seeds. CPU seconds are user + system of the render (both threads), so a busy"
  echo "machine inflates them less than wall-clock time, though not by nothing (caches, frequency);"
  echo "the ratio is measured side by side in one run and is the figure to trust, not the absolute"
  echo "seconds. Reference: two halves of $REF_SPP spp with spectral MIS (seeds 900001, 900002,"
  echo "$(printf '%.0f' "$REF_CPU") CPU s); its own noise, $(pct "$FLOOR_LUM") (luminance) and $(pct "$FLOOR_COL") (colour), is subtracted in"
  echo "quadrature from every error below. *Energy*: mean Y (R, G, B) over the reference's; both"
  echo "strategies are unbiased, so both should be 1 within the noise."
  echo
  echo "| strategy | spp | CPU s | wall s | colour | luminance | colour raw | luminance raw | energy Y (R, G, B) |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  awk -F'\t' '{ printf "| %s | %d | %.3f | %.3f | %s | %s | %s | %s | %.3f (%.3f, %.3f, %.3f) |\n",
      ($1 == "mis" ? "spectral MIS" : "terminate"), $2, $3, $4, pc($8), pc($7), pc($6), pc($5), $9, $10, $11, $12 }
    function pc(v) { v *= 100; return v < 0.095 ? sprintf("%.2f %%", v) : v < 9.95 ? sprintf("%.1f %%", v) : sprintf("%.0f %%", v) }' \
    <(sort -t$'\t' -k1,1 -k2,2n "$WORK/points.tsv")
  echo
  echo "*Noise × time*: error² × CPU s per point, constant where the error falls as 1/√(CPU s); the"
  echo "smaller, the faster the noise goes, and where both strategies are flat in spp their ratio is"
  echo "the ratio of CPU times to the same error:"
  echo
  echo "| spp | colour, MIS | colour, terminate | terminate / MIS | luminance, MIS | luminance, terminate | terminate / MIS |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  awk -F'\t' '{ printf "| %d | %.4g | %.4g | %.2f | %.4g | %.4g | %.2f |\n", $1, $2, $3, $4, $5, $6, $7 }' "$WORK/nt.tsv"
  echo
  if [[ -s $WORK/ratio.tsv ]]; then
    echo "**CPU time to reach the same colour error**, each curve interpolated on log-log between the"
    echo "measured points that bracket the error, at every measured error inside the range both curves"
    echo "cover:"
    echo
    echo "| colour error | CPU s, spectral MIS | CPU s, terminate | terminate / MIS |"
    echo "| --- | --- | --- | --- |"
    awk -F'\t' '{ printf "| %.1f %% | %.3f | %.3f | %.2f |\n", 100 * $1, $2, $3, $4 }' "$WORK/ratio.tsv"
    echo
    echo "Geometric mean of the ratio: **$RATIO** (from $RATIO_LO to $RATIO_HI)."
  else
    echo "The two colour-error curves do not overlap: no ratio at equal error."
  fi
  echo
  if ((PLOT)); then
    echo "![spectral MIS against termination](accuracy/spectral_mis.png)"
  else
    echo "(No plot: gnuplot was not installed when this ran.)"
  fi
  echo
  if [[ $RATIO != - ]]; then
    awk -v r="$RATIO" -v lo="$RATIO_LO" -v hi="$RATIO_HI" -v a="$NT_RATIO" -v n="$NT_SPP" -v l="$NT_LUM" 'BEGIN {
      if (r > 1.1) printf "**Conclusion.** Spectral MIS, the default, is the better one here: termination needs %.2f times\nthe CPU time for the same colour error, interpolated over the range both curves cover (%.2f to\n%.2f at the errors above), and %.1f times by noise × time at %d spp, the most measured (see above\nwhether noise × time is flat there, i.e. the curves fall as 1/√t).", r, lo, hi, a, n
      if (r > 1.1) printf (l > 0.8 && l < 1.25 ? " The luminance error is about the same for both (noise × time ratio %.2f):\nthe secondaries carry colour, not brightness.\n" : " Luminance: noise × time ratio %.2f.\n"), l
      else if (r < 1 / 1.1) printf "**Conclusion.** Termination is the better one here: spectral MIS needs %.2f times the CPU\ntime for the same colour error (noise × time ratio %.1f at %d spp); the default should be\nreconsidered.\n", 1 / r, a, n
      else printf "**Conclusion.** No clear winner: the CPU times to the same colour error differ by a factor\n%.2f (noise × time ratio %.1f at %d spp), within what one run on a shared machine can tell\napart.\n", r, a, n }'
  fi
} >"$WORK/report.md"

cat "$WORK/report.md"
if ((WRITE_DOCS)); then
  DOC=$ROOT/docs/accuracy.md
  if ! grep -q '<!-- spectral_mis:begin -->' "$DOC" 2>/dev/null; then
    printf '\n<!-- spectral_mis:begin -->\n<!-- spectral_mis:end -->\n' >>"$DOC"
  fi
  awk -v rep="$WORK/report.md" '
    /<!-- spectral_mis:begin -->/ { print; while ((getline l < rep) > 0) print l; skip = 1; next }
    /<!-- spectral_mis:end -->/ { skip = 0 }
    !skip' "$DOC" >"$WORK/doc.md"
  cp "$WORK/doc.md" "$DOC"
  echo "== wrote the section into $DOC$( ((PLOT)) && echo " and the plot into $OUT/spectral_mis.png")" >&2
else
  cp "$WORK/report.md" "$WORK"/*.tsv "$OUT/"
  echo "== the report, data and plot are in $OUT" >&2
fi
