#!/usr/bin/env bash
# What the effect plan saves (docs/plan.md): `prismfarm render --direct` with what integrator
# "auto" chooses against the same scene with an absent effect forced on:
#   1. photon pass forced on scenes without caustic paths -- a mirror no diffuse surface sees,
#      and the Cornell box without its glass cube: the pass stores nothing, so the pixel data
#      must be identical (EXR pixel data compared);
#   2. fan-out forced on a scene without dispersion (the Cornell box, constant-index glass):
#      nothing ever splits, so the image is the same up to colour noise;
#   3. photon pass forced where a large light makes path tracing enough (the Cornell box with
#      its glass: the plan leaves the caustic of its 0.076 sr light to the path tracer);
# and the cost of planning itself: `prismfarm plan` on every shipped scene.
# Each figure is the median of --reps runs: wall and CPU (user + system) seconds, process
# start to exit.
#
# usage: bash bench/plan.sh [--reps N] [--build DIR] [--no-build] [--res WxH] [--spp N]
#   --reps N    repetitions (default 5)
#   --build DIR Release build folder (default build-bench in the repository); built first
#   --no-build  use DIR/cli/prismfarm as it is
#   --res WxH   image size (default 200x200); --spp N samples (default 16)
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
REPS=5
BUILD=$ROOT/build-bench
DO_BUILD=1
RES=200x200
SPP=16
while (($#)); do
  case $1 in
    --reps) REPS=${2:-}; shift 2 ;;
    --build) BUILD=${2:-}; shift 2 ;;
    --no-build) DO_BUILD=0; shift ;;
    --res) RES=${2:-}; shift 2 ;;
    --spp) SPP=${2:-}; shift 2 ;;
    -h|--help) sed -n '2,19p' "$0"; exit 0 ;;
    *) echo "bench/plan.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ $REPS =~ ^[1-9][0-9]*$ ]] || { echo "bench/plan.sh: --reps expects a positive integer" >&2; exit 2; }
[[ $SPP =~ ^[1-9][0-9]*$ ]] || { echo "bench/plan.sh: --spp expects a positive integer" >&2; exit 2; }
[[ $RES =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || { echo "bench/plan.sh: --res expects WxH" >&2; exit 2; }

if ((DO_BUILD)); then
  echo "== building Release into $BUILD" >&2
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD" -j"$(nproc)" --target prismfarm >/dev/null
fi
BIN=$BUILD/cli/prismfarm
[[ -x $BIN ]] || { echo "bench/plan.sh: no $BIN (build it, or drop --no-build)" >&2; exit 1; }

WORK=$(mktemp -d /tmp/prismfarm-plan-bench-XXXXXX)
trap 'rm -rf "$WORK"' EXIT

elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", b - a }'; }
# "median min max" of the arguments.
stats() { printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END {
  m = NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2; printf "%.3f %.3f %.3f\n", m, v[1], v[NR] }'; }
med() { stats "$@" | cut -d' ' -f1; }

# ---------------------------------------------------------------- the scene variants

CORNELL=$ROOT/scenes/cornell.pbrt
# The Cornell box with another Integrator line (the file's is one line).
with_integrator() { # out integrator-line
  awk -v line="$2" '/^Integrator / { print line; next } { print }' "$CORNELL" >"$1"
}
# ... and without the glass cube: the AttributeBegin..AttributeEnd block around the only
# dielectric.
without_glass() { # in out
  awk '{ l[NR] = $0 } /Material "dielectric"/ { d = NR }
       END { for (b = d; b > 0 && l[b] !~ /^AttributeBegin/; b--) ;
             for (e = d; e <= NR && l[e] !~ /^AttributeEnd/; e++) ;
             for (i = 1; i <= NR; i++) if (i < b || i > e) print l[i] }' "$1" >"$2"
}
PHOTON_LINE='Integrator "photon" "integer maxdepth" [ 8 ] "integer photons" [ 1000000 ]'
with_integrator "$WORK/auto.pbrt" 'Integrator "auto" "integer maxdepth" [ 8 ]'
with_integrator "$WORK/photon.pbrt" "$PHOTON_LINE"
without_glass "$WORK/auto.pbrt" "$WORK/auto_noglass.pbrt"
without_glass "$WORK/photon.pbrt" "$WORK/photon_noglass.pbrt"
if grep -q dielectric "$WORK/auto_noglass.pbrt"; then
  echo "bench/plan.sh: could not remove the glass from $CORNELL" >&2
  exit 1
fi
# A mirror facing the open sky above a grey floor, under a point light: light reaches the
# mirror, but no diffuse surface sees its face, so there is no caustic path; photons are
# still aimed at the mirror and traced (tests/unit/test_plan.c has the same scene).
mirror_scene() { # out integrator-line
  cat >"$1" <<SCENE
LookAt 0 2.5 -4  0 -0.3 0  0 1 0
Camera "perspective" "float fov" [ 45 ]
Film "rgb" "integer xresolution" [ 200 ] "integer yresolution" [ 200 ]
Sampler "independent" "integer pixelsamples" [ 16 ]
$2
WorldBegin
MakeNamedMaterial "floor" "string type" "diffuse" "rgb reflectance" [ 0.5 0.45 0.4 ]
MakeNamedMaterial "mirror" "string type" "conductor" "float reflectance" 0.9
NamedMaterial "floor"
Shape "trianglemesh" "point3 P" [ -5 -1 -5  5 -1 -5  5 -1 5  -5 -1 5 ] "integer indices" [ 0 1 2  0 2 3 ]
AttributeBegin
  NamedMaterial "mirror"
  Rotate -90 1 0 0
  Shape "disk" "float radius" 0.5
AttributeEnd
LightSource "point" "point3 from" [ 0 2 0 ] "float scale" 5
SCENE
}
mirror_scene "$WORK/mirror_auto.pbrt" 'Integrator "auto" "integer maxdepth" [ 8 ]'
mirror_scene "$WORK/mirror_photon.pbrt" "$PHOTON_LINE"

# One render: prints "WALL CPU" seconds (process start to exit; CPU is user + system, which
# other jobs on the machine disturb less); the EXR goes to $WORK/$2.exr.
render() { # scene out [options...]
  local scene=$1 out=$2 t
  shift 2
  t=$( { TIMEFORMAT='%R %U %S'; time "$BIN" render "$scene" --res "$RES" --spp "$SPP" --direct \
          --quiet -o "$WORK/$out.exr" "$@" >/dev/null 2>"$WORK/$out.err"; } 2>&1 ) ||
    { cat "$WORK/$out.err" >&2; exit 1; }
  awk '{ printf "%.3f %.3f\n", $1, $2 + $3 }' <<<"$t"
}

# The pixel data of two EXR files compared without the header, whose metadata names the scene
# file and the render time: the bytes from the first chunk on, where the offset table after
# the header points (OpenEXR file layout: magic and version, then attributes "name\0type\0"
# size value, ended by an empty name, then the offset table).
same_pixels() { # a.exr b.exr
  if ! command -v python3 >/dev/null; then
    echo "not compared (no python3)"
    return
  fi
  python3 - "$1" "$2" <<'PY'
import struct, sys
def pixels(path):
    b = open(path, "rb").read()
    i = 8
    while b[i] != 0:
        i = b.index(b"\0", i) + 1  # name
        i = b.index(b"\0", i) + 1  # type
        (n,) = struct.unpack_from("<i", b, i)
        i += 4 + n
    (first,) = struct.unpack_from("<Q", b, i + 1)
    return b[first:]
print("identical" if pixels(sys.argv[1]) == pixels(sys.argv[2]) else "differ")
PY
}

# What the plan chooses for a variant, in a few words.
plan_says() { # scene
  "$BIN" plan "$1" --res "$RES" --spp "$SPP" --json |
    awk -F'"' '/"choice": \{/ { c = 1 } c && /"photon":/ && !p { p = $0 ~ /true/ ? "photon" : "path" }
               c && /"dispersion":/ && !d { d = $4 } END { printf "%s, %s", p, d }'
}

CPU=$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')
echo "== $CPU, $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg); $RES, $SPP spp, median of $REPS runs" >&2

# name | the plan's scene and options | the forced scene and options | what is forced on
CASES=(
  "mirror, no caustic|$WORK/mirror_auto.pbrt|$WORK/mirror_photon.pbrt|photon pass, 1e6"
  "cornell, no glass|$WORK/auto_noglass.pbrt|$WORK/photon_noglass.pbrt|photon pass, 1e6"
  "cornell|$WORK/auto.pbrt|$WORK/auto.pbrt --dispersion fanout|fan-out, 16 lanes"
  "cornell|$WORK/auto.pbrt|$WORK/photon.pbrt|photon pass, 1e6"
)

printf '\n%-19s %-12s %-17s %15s %15s %9s %s\n' "scene" "plan" "forced on" "plan wall/cpu" \
  "forced wall/cpu" "cpu saved" "pixels"
for c in "${CASES[@]}"; do
  IFS='|' read -r name planned forced what <<<"$c"
  read -r -a pa <<<"$planned"
  read -r -a fa <<<"$forced"
  pw=() pc=() fw=() fc=()
  for ((r = 0; r < REPS; r++)); do
    read -r w u <<<"$(render "${pa[0]}" plan "${pa[@]:1}")"
    pw+=("$w") pc+=("$u")
    read -r w u <<<"$(render "${fa[0]}" forced "${fa[@]:1}")"
    fw+=("$w") fc+=("$u")
  done
  mpc=$(med "${pc[@]}") mfc=$(med "${fc[@]}")
  saved=$(awk -v a="$mpc" -v b="$mfc" 'BEGIN { printf "%.0f%%", 100 * (b - a) / b }')
  printf '%-19s %-12s %-17s %7s/%-7s %7s/%-7s %9s %s\n' "$name" "$(plan_says "${pa[0]}")" "$what" \
    "$(med "${pw[@]}")" "$mpc" "$(med "${fw[@]}")" "$mfc" "$saved" \
    "$(same_pixels "$WORK/plan.exr" "$WORK/forced.exr")"
done

printf '\n%-24s %9s %s\n' "prismfarm plan" "seconds" "rays"
for f in "$ROOT"/scenes/*.pbrt; do
  ts=()
  for ((r = 0; r < REPS; r++)); do
    t0=$EPOCHREALTIME
    "$BIN" plan "$f" >"$WORK/plan.txt"
    ts+=("$(elapsed "$t0" "$EPOCHREALTIME")")
  done
  rays=$(sed -n 's/^(\([0-9]*\) visibility rays)$/\1/p' "$WORK/plan.txt")
  printf '%-24s %9s %s\n' "$(basename "$f")" "$(med "${ts[@]}")" "$rays"
done
