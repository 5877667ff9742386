#!/usr/bin/env bash
# The renderer's throughput against Embree's (docs/throughput.md), in one run:
#   bench_throughput on every scenes/*.pbrt (rays/s of the path tracer with 1 thread and every
#   core, the same rays replayed on Embree alone with rtcIntersect1/rtcOccluded1 and with its
#   stream and packet queries, local_render's scaling over 1..N threads, photons per CPU second),
#   then a perf profile of the renderer on the scene with the lowest renderer/Embree ratio:
#   where the time that is not Embree's goes.
# Prints the tables and rewrites the part of docs/throughput.md between its
# "throughput:begin" and "throughput:end" markers.
#
# usage: bash bench/throughput.sh [--reps N] [--res WxH] [--spp N] [--build DIR] [--no-build]
#                                 [--no-perf] [--no-docs]
#   --reps N    repetitions of every figure (default 3): about 4 minutes on 2 idle cores
#   --res WxH   image size of every scene (default 160x120); --spp N samples (default 16)
#   --build DIR Release build folder (default build-bench in the repository); built first
#   --no-build  use DIR/bench/bench_throughput as it is
#   --no-perf   skip the profile (it needs perf and perf_event_paranoid <= 2)
#   --no-docs   print the tables only
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
REPS=3
RES=160x120
SPP=16
BUILD=$ROOT/build-bench
DO_BUILD=1
DO_PERF=1
WRITE_DOCS=1
while (($#)); do
  case $1 in
    --reps) REPS=${2:-}; shift 2 ;;
    --res) RES=${2:-}; shift 2 ;;
    --spp) SPP=${2:-}; shift 2 ;;
    --build) BUILD=${2:-}; shift 2 ;;
    --no-build) DO_BUILD=0; shift ;;
    --no-perf) DO_PERF=0; shift ;;
    --no-docs) WRITE_DOCS=0; shift ;;
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    *) echo "bench/throughput.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ $REPS =~ ^[1-9][0-9]*$ ]] || { echo "bench/throughput.sh: --reps expects a positive integer" >&2; exit 2; }
[[ $SPP =~ ^[1-9][0-9]*$ ]] || { echo "bench/throughput.sh: --spp expects a positive integer" >&2; exit 2; }
[[ $RES =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || { echo "bench/throughput.sh: --res expects WxH" >&2; exit 2; }
if ((DO_PERF)) && ! command -v perf >/dev/null; then
  echo "bench/throughput.sh: no perf: the profile is skipped" >&2
  DO_PERF=0
fi

if ((DO_BUILD)); then
  echo "== building Release into $BUILD" >&2
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" -j"$(nproc)" --target bench_throughput >/dev/null
fi
BIN=$BUILD/bench/bench_throughput
[[ -x $BIN ]] || { echo "bench/throughput.sh: no $BIN (build it, or drop --no-build)" >&2; exit 1; }

WORK=$(mktemp -d /tmp/prismfarm-throughput-XXXXXX)
trap 'rm -rf "$WORK"' EXIT

echo "== bench_throughput: $REPS repetitions at $RES, $SPP spp" >&2
"$BIN" --reps "$REPS" --res "$RES" --spp "$SPP" >"$WORK/report.md"

# ---------------------------------------------------------------- the profile

# Scenes by their renderer / rtcIntersect1 ratio (column 6 of the first table), lowest first.
by_ratio() {
  awk -F'|' '/^$/ && seen { done = 1 } /^\| scene/ { seen = 1 }
             /^\| `/ && !done { gsub(/[ `]/, "", $2); printf "%s %s\n", $6 + 0, $2 }' \
    "$WORK/report.md" | sort -g | cut -d' ' -f2
}
# Scenes in the photon table (a photon pass: the camera pass gathers from its store).
photon_scenes() {
  awk -F'|' '/^\*\*Photons/ { on = 1 } on && /^\| `/ { gsub(/[ `]/, "", $2); print $2 }' "$WORK/report.md"
}

# perf profile of the renderer alone on one scene.
profile() { # scene why
  local scene=$1 why=$2 window
  echo "== perf profile of the renderer on $scene" >&2
  # Sample timestamps on CLOCK_MONOTONIC, so that the renders' window (which bench_throughput
  # --profile prints) leaves out the scene's loading and photon pass.
  if ! perf record -q -k CLOCK_MONOTONIC -F 1999 -o "$WORK/perf.data" \
      "$BIN" --profile --reps "$REPS" --res "$RES" --spp "$SPP" "$ROOT/scenes/$scene" \
      >"$WORK/profile.out" 2>"$WORK/profile.err"; then
    echo "bench/throughput.sh: perf record failed (perf_event_paranoid?): profile skipped" >&2
    return 0
  fi
  window=$(sed -n 's/^profile window [^:]*: //p' "$WORK/profile.err")
  perf report -i "$WORK/perf.data" --time "$window" --no-children --sort dso,sym -t ';' --stdio \
    -g none 2>/dev/null | grep -v '^#' | grep -v '^$' >"$WORK/symbols.txt" || true
  echo
  echo "**Where the renderer's time goes** on \`$scene\` ($why): \`perf record\` of"
  echo "\`bench_throughput --profile\` (single-thread renders at $RES, $SPP spp, $REPS of them; loading"
  echo "and photon pass left out), share of the CPU samples. Embree's share counts the callbacks it"
  echo "makes during traversal (geometry.c's mesh_filter, analytic_intersect, analytic_occluded)."
  echo
  echo "| part | share |"
  echo "| --- | --- |"
  awk -F';' '
    { p = $1; sub(/%/, "", p); d = $2; gsub(/ /, "", d); s = $3; sub(/^ *\[[.k]\] */, "", s); gsub(/ +$/, "", s)
      if (d ~ /libembree/ || s ~ /^(mesh_filter|analytic_intersect|analytic_occluded)$/) k = "Embree traversal"
      else if (d ~ /^libm/) k = "libm (sin, cos, exp, ...)"
      else if (d ~ /kallsyms|kernel/) k = "kernel"
      else if (d ~ /^libc/) k = "libc (memcpy, malloc, ...)"
      else k = "prismfarm (shading, lights, spectra, sampling, photon gather)"
      share[k] += p }
    END { for (k in share) printf "%.1f;%s\n", share[k], k }' "$WORK/symbols.txt" |
    sort -t';' -k1,1gr | awk -F';' '{ printf "| %s | %.1f %% |\n", $2, $1 }'
  echo
  echo "| function | library | share |"
  echo "| --- | --- | --- |"
  head -15 "$WORK/symbols.txt" | awk -F';' '{ p = $1; gsub(/ /, "", p); d = $2; gsub(/ /, "", d)
    s = $3; sub(/^ *\[[.k]\] */, "", s); gsub(/ +$/, "", s)
    if (s ~ /^0x/) s = "(no symbol)"; if (d == "bench_throughput") d = "prismfarm"
    printf "| `%s` | %s | %s |\n", s, d, p }'
}

if ((DO_PERF)); then
  # The lowest ratio of all, and the lowest of the scenes without a photon pass (whose camera
  # pass is the path tracer alone).
  mapfile -t ORDER < <(by_ratio)
  mapfile -t PHOTON < <(photon_scenes)
  PATH_WORST=
  for s in "${ORDER[@]}"; do
    [[ " ${PHOTON[*]} " == *" $s "* ]] || { PATH_WORST=$s; break; }
  done
  if ((${#ORDER[@]})); then
    profile "${ORDER[0]}" "the lowest ratio" >>"$WORK/profile.md"
    if [[ -n $PATH_WORST && $PATH_WORST != "${ORDER[0]}" ]]; then
      profile "$PATH_WORST" "the lowest ratio without a photon pass" >>"$WORK/profile.md"
    fi
    cat "$WORK/profile.md" >>"$WORK/report.md"
  fi
fi

# ---------------------------------------------------------------- a complex scene

# The shipped scenes have tens to hundreds of triangles. The same booth with its analytic glass
# sphere replaced by a tessellated one of 1 M triangles (same glass, smooth vertex normals)
# shows the ratio where Embree has real work: generated here, never shipped (26 MB).
MESH_BIN=$BUILD/bench/bench_mesh_sphere
if ((DO_BUILD)); then
  cmake --build "$BUILD" -j"$(nproc)" --target bench_mesh_sphere >/dev/null
fi
if [[ -x $MESH_BIN ]]; then
  echo "== the booth with a 1 M-triangle sphere" >&2
  mkdir -p "$WORK/mesh"
  cp -r "$ROOT/scenes/geometry" "$WORK/mesh/"
  "$MESH_BIN" "$WORK/mesh/sphere.ply" 0.6 1024 512 >"$WORK/mesh/ply.out"
  sed 's|Shape "sphere" "float radius" \[ 0.6 \]|Shape "plymesh" "string filename" "sphere.ply"|' \
    "$ROOT/scenes/sphere_booth.pbrt" >"$WORK/mesh/sphere_mesh.pbrt"
  grep -q plymesh "$WORK/mesh/sphere_mesh.pbrt" || { echo "bench/throughput.sh: sphere_booth.pbrt changed" >&2; exit 1; }
  "$BIN" --reps "$REPS" --res "$RES" --spp "$SPP" --threads 1 "$WORK/mesh/sphere_mesh.pbrt" \
    "$ROOT/scenes/sphere_booth.pbrt" >"$WORK/mesh.md"
  {
    echo
    echo "**A scene of real geometric complexity** (generated by the bench, not shipped:"
    echo "\`sphere_booth.pbrt\` with its analytic N-SF11 sphere replaced by a tessellated one of"
    echo "$(sed 's/,.*//' "$WORK/mesh/ply.out") and $(sed 's/.*, //' "$WORK/mesh/ply.out") with vertex normals,"
    echo "\`sphere_mesh.pbrt\`, beside the shipped scene measured in the same process; one thread, CPU time)"
    echo
    awk '/^\*\*Renderer against Embree/ { on = 1; next } on && /^$/ && rows { exit }
         on && /^\|/ { print; rows++ }' "$WORK/mesh.md"
  } >>"$WORK/report.md"
fi

cat "$WORK/report.md"

if ((WRITE_DOCS)); then
  DOC=$ROOT/docs/throughput.md
  if ! grep -q '<!-- throughput:begin -->' "$DOC" 2>/dev/null; then
    printf '\n<!-- throughput:begin -->\n<!-- throughput:end -->\n' >>"$DOC"
  fi
  awk -v rep="$WORK/report.md" '
    /<!-- throughput:begin -->/ { print; while ((getline l < rep) > 0) print l; skip = 1; next }
    /<!-- throughput:end -->/ { skip = 0 }
    !skip' "$DOC" >"$WORK/doc.md"
  cp "$WORK/doc.md" "$DOC"
  echo "== wrote the tables into $DOC" >&2
fi
