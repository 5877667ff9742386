#!/usr/bin/env bash
# Same pixels after a refactor: proves that the working tree renders every shipped scene to the
# same EXR pixel data, bit for bit, as an earlier revision.
#
# It builds BASE_REV (Release) in a temporary `git worktree` outside the source tree (removed
# at exit) and the working tree in build-pixels/ of the source tree (its own Release build, so
# that a Debug or sanitizer build in build/ is never used), finds each build's `prismfarm`
# executable wherever it lives (`find BUILD -type f -name prismfarm -perm -u+x`), and renders,
# with each revision's binary and each revision's own scenes/ folder:
#
#   every scenes/*.pbrt of the working tree
#   x integrator: the scene's own (no --integrator: a photon scene renders as a photon scene),
#                 and --integrator path | simplepath | whitted (the CLI's choices; on a photon
#                 scene they replace the photon integrator)
#   x --dispersion hero | fanout
#   x --direct (plain threads) and without it (the farm in one process)
#   at --res 96x72 --spp 8 --threads 2 --quiet.
#
# Each pair of EXRs is compared on its pixel data only (every part, level and channel: name,
# type, size and sample bytes) by bench_exr_pixels (bench/exr_pixels.c, built from the working
# tree), not on file bytes: the header holds timings and job strings that differ from run to
# run. A combination that both revisions refuse (exit status 1 or 2 with a message) is skipped;
# one refused by only one of them, a crash or a time-out is a failure and counts as different.
#
# Output: a Markdown table on stdout (scene, integrator, dispersion, mode, result) and a last
# line "N identical, M different, K skipped"; progress and timings on stderr. Exit status 0
# only if nothing differs and at least one pair was compared; 1 otherwise; 2 for bad usage.
#
# usage: bash bench/same_pixels.sh [BASE_REV] [--keep DIR]
#   BASE_REV    revision to compare against (default e26f0bf, the commit before the
#               reorganisation of the source folders)
#   --keep DIR  keep BASE_REV's renders in DIR/<full commit id>/ and reuse them: a second run
#               neither builds nor renders BASE_REV (only combinations missing from DIR are
#               rendered). The working tree's renders of the last run are left in DIR/current/
#               for a look at any difference. Runs given the same DIR wait for each other. A
#               cache is only as good as the machine it was made on: delete DIR/<commit> after a
#               compiler or library upgrade.
#   environment: PIXELS_JOBS (build parallelism, default 2), PIXELS_TIMEOUT (seconds per
#               render, default 600)
#
# A full run (two builds and 256 renders) took 6 minutes on the 2 shared cores (load average
# 7), a run with the base cached 3 minutes. See docs/performance.md, "Same pixels after a
# refactor".
set -euo pipefail

DEFAULT_BASE=e26f0bf
RES=96x72
SPP=8
THREADS=2
INTEGRATORS=(scene path simplepath whitted)
DISPERSIONS=(hero fanout)
MODES=(direct farm)
JOBS=${PIXELS_JOBS:-2}
TIMEOUT=${PIXELS_TIMEOUT:-600}
# What the cached base renders depend on besides the commit; a cache made with other settings
# is rendered again.
SETTINGS="same_pixels v1: --res $RES --spp $SPP --threads $THREADS --quiet"

me=bench/same_pixels.sh
die() { echo "$me: $*" >&2; exit 2; }
log() { echo "$*" >&2; }

BASE_REV=
KEEP=
while (($#)); do
  case $1 in
    --keep) [[ $# -ge 2 && -n $2 ]] || die "--keep needs a folder"; KEEP=$2; shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    -*) die "unknown option '$1' (see --help)" ;;
    *) [[ -z $BASE_REV ]] || die "more than one BASE_REV given ('$BASE_REV' and '$1')"; BASE_REV=$1; shift ;;
  esac
done
BASE_REV=${BASE_REV:-$DEFAULT_BASE}
[[ $JOBS =~ ^[1-9][0-9]*$ ]] || die "PIXELS_JOBS expects a positive integer"
[[ $TIMEOUT =~ ^[1-9][0-9]*$ ]] || die "PIXELS_TIMEOUT expects a positive integer"

SRC=$(git -C "$(dirname "$0")" rev-parse --show-toplevel)
cd "$SRC"
BASE_SHA=$(git rev-parse --verify --quiet "$BASE_REV^{commit}") || die "'$BASE_REV' is not a commit of this repository"
if [[ -n $KEEP ]]; then
  mkdir -p "$KEEP"
  KEEP=$(cd "$KEEP" && pwd)
fi

WORK=$(mktemp -d "${TMPDIR:-/tmp}/same-pixels.XXXXXX")
BASE_TREE=$WORK/base-src
cleanup() {
  if [[ -e $BASE_TREE ]]; then
    git -C "$SRC" worktree remove --force "$BASE_TREE" >/dev/null 2>&1 || true
  fi
  rm -rf "$WORK"
  git -C "$SRC" worktree prune >/dev/null 2>&1 || true
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# build SRC_DIR BUILD_DIR LABEL: a Release build without the tests (they are not needed here
# and are most of the build's time).
build() {
  local t0=$SECONDS blog=$WORK/build-$3.log
  log "building $3 ($1) in $2 ..."
  if ! { cmake -S "$1" -B "$2" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF &&
         cmake --build "$2" -j "$JOBS"; } >"$blog" 2>&1; then
    tail -n 30 "$blog" >&2
    echo "$me: the build of $3 failed (log above)" >&2
    exit 1
  fi
  log "built $3 in $((SECONDS - t0)) s"
}

# find_exe BUILD_DIR NAME: the one executable file NAME under BUILD_DIR.
find_exe() {
  local found
  mapfile -t found < <(find "$1" -type f -name "$2" -perm -u+x)
  [[ ${#found[@]} -eq 1 ]] || { echo "$me: expected one executable '$2' under $1, found ${#found[@]}: ${found[*]}" >&2; exit 1; }
  echo "${found[0]}"
}

# render BIN TREE NAME INTEGRATOR DISPERSION MODE OUT_PREFIX: renders TREE/scenes/NAME.pbrt
# (from TREE, so that the scene's relative includes resolve as for a user) into
# OUT_PREFIX.exr, with its stderr in OUT_PREFIX.err and, written last, its exit status in
# OUT_PREFIX.rc.
render() {
  local bin=$1 tree=$2 name=$3 integ=$4 disp=$5 mode=$6 out=$7 rc=0
  local args=(render "scenes/$name.pbrt" --res "$RES" --spp "$SPP" --threads "$THREADS" --quiet
              --dispersion "$disp" -o "$out.exr")
  [[ $integ == scene ]] || args+=(--integrator "$integ")
  [[ $mode == direct ]] && args+=(--direct)
  rm -f "$out.exr" "$out.png" "$out.err" "$out.rc"
  (cd "$tree" && exec timeout "$TIMEOUT" "$bin" "${args[@]}") >/dev/null 2>"$out.err" || rc=$?
  rm -f "$out.png" "$out.exr.tmp"
  echo "$rc" >"$out.rc.tmp" && mv "$out.rc.tmp" "$out.rc"
}

# The combinations, from the working tree's scenes.
shopt -s nullglob
scene_files=(scenes/*.pbrt)
shopt -u nullglob
((${#scene_files[@]})) || die "no scenes/*.pbrt in $SRC"
combos=()
for f in "${scene_files[@]}"; do
  name=$(basename "$f" .pbrt)
  for integ in "${INTEGRATORS[@]}"; do
    for disp in "${DISPERSIONS[@]}"; do
      for mode in "${MODES[@]}"; do
        combos+=("$name $integ $disp $mode")
      done
    done
  done
done

# Where the renders go: the working tree's in the temporary folder (copied to DIR/current at
# the end), BASE_REV's in DIR/<commit> with --keep. Runs sharing DIR take turns (a lock on
# DIR/.lock, held until this script exits).
CUR_OUT=$WORK/current
if [[ -n $KEEP ]]; then
  exec 9>>"$KEEP/.lock"
  if ! flock -n 9; then
    log "another run is using $KEEP: waiting for it to finish ..."
    flock 9
  fi
  BASE_OUT=$KEEP/$BASE_SHA
  if [[ -d $BASE_OUT && "$(cat "$BASE_OUT/settings" 2>/dev/null)" != "$SETTINGS" ]]; then
    log "the renders in $BASE_OUT were made with other settings: rendering them again"
    rm -rf "$BASE_OUT"
  fi
else
  BASE_OUT=$WORK/base
fi
mkdir -p "$BASE_OUT" "$CUR_OUT"
echo "$SETTINGS" >"$BASE_OUT/settings"

missing=()
for c in "${combos[@]}"; do
  read -r name integ disp mode <<<"$c"
  [[ -f $BASE_OUT/$name.$integ.$disp.$mode.rc ]] || missing+=("$c")
done

t_start=$SECONDS
# The working tree first: it builds the comparison tool too.
build "$SRC" "$SRC/build-pixels" "the working tree"
CUR_BIN=$(find_exe "$SRC/build-pixels" prismfarm)
TOOL=$(find_exe "$SRC/build-pixels" bench_exr_pixels)

if ((${#missing[@]})); then
  git -C "$SRC" worktree add --detach "$BASE_TREE" "$BASE_SHA" >/dev/null 2>&1 ||
    { echo "$me: git worktree add $BASE_TREE $BASE_SHA failed" >&2; exit 1; }
  build "$BASE_TREE" "$WORK/build-base" "$BASE_REV"
  BASE_BIN=$(find_exe "$WORK/build-base" prismfarm)
  t0=$SECONDS
  log "rendering ${#missing[@]} combinations with $BASE_REV ($BASE_BIN) into $BASE_OUT ..."
  i=0
  for c in "${missing[@]}"; do
    read -r name integ disp mode <<<"$c"
    i=$((i + 1))
    log "  [$i/${#missing[@]}] $BASE_REV: $name $integ $disp $mode"
    render "$BASE_BIN" "$BASE_TREE" "$name" "$integ" "$disp" "$mode" "$BASE_OUT/$name.$integ.$disp.$mode"
  done
  log "rendered $BASE_REV in $((SECONDS - t0)) s"
else
  log "all ${#combos[@]} renders of $BASE_REV ($BASE_SHA) are cached in $BASE_OUT"
fi

t0=$SECONDS
log "rendering ${#combos[@]} combinations with the working tree ($CUR_BIN) into $CUR_OUT ..."
i=0
for c in "${combos[@]}"; do
  read -r name integ disp mode <<<"$c"
  i=$((i + 1))
  log "  [$i/${#combos[@]}] working tree: $name $integ $disp $mode"
  render "$CUR_BIN" "$SRC" "$name" "$integ" "$disp" "$mode" "$CUR_OUT/$name.$integ.$disp.$mode"
done
log "rendered the working tree in $((SECONDS - t0)) s"

# first_line FILE: the file's first non-empty line, with '|' escaped for the table.
first_line() { grep -m1 -v '^[[:space:]]*$' "$1" 2>/dev/null | sed 's/|/\\|/g' || true; }
# Exit statuses 1 and 2 are prismfarm's "cannot do that" (bad option, scene it cannot load);
# anything else (a signal, timeout's 124, ...) is a crash.
is_refusal() { [[ $1 == 1 || $1 == 2 ]]; }

n_same=0 n_diff=0 n_skip=0
rows=()
for c in "${combos[@]}"; do
  read -r name integ disp mode <<<"$c"
  b=$BASE_OUT/$name.$integ.$disp.$mode c_=$CUR_OUT/$name.$integ.$disp.$mode
  brc=$(cat "$b.rc") crc=$(cat "$c_.rc")
  label=$integ
  if [[ $integ == scene ]]; then
    declared=$(sed -n 's/^[[:space:]]*Integrator[[:space:]]*"\([^"]*\)".*/\1/p' "scenes/$name.pbrt" | head -n 1)
    label="scene's (${declared:-as declared})"
  fi
  if [[ $brc == 0 && $crc == 0 ]]; then
    out=$("$TOOL" compare "$b.exr" "$c_.exr" 2>/dev/null) && trc=0 || trc=$?
    if ((trc == 0)); then
      result=identical; n_same=$((n_same + 1))
    else
      result="DIFFERENT ($(sed 's/^DIFFERENT: //; s/|/\\|/g' <<<"$out" | head -n 1))"; n_diff=$((n_diff + 1))
    fi
  elif is_refusal "$brc" && is_refusal "$crc"; then
    bmsg=$(first_line "$b.err") cmsg=$(first_line "$c_.err")
    if [[ $bmsg == "$cmsg" ]]; then
      result="skipped (refused by both: $cmsg)"
    else
      result="skipped (refused by both: $BASE_REV: $bmsg; working tree: $cmsg)"
    fi
    n_skip=$((n_skip + 1))
  elif [[ $brc == 0 ]] && is_refusal "$crc"; then
    result="DIFFERENT (FAILURE: refused by the working tree only: $(first_line "$c_.err"))"; n_diff=$((n_diff + 1))
  elif [[ $crc == 0 ]] && is_refusal "$brc"; then
    result="DIFFERENT (FAILURE: refused by $BASE_REV only: $(first_line "$b.err"))"; n_diff=$((n_diff + 1))
  else
    why=
    is_refusal "$brc" || [[ $brc == 0 ]] || why="$BASE_REV crashed (exit $brc: $(first_line "$b.err"))"
    is_refusal "$crc" || [[ $crc == 0 ]] || why="${why:+$why; }the working tree crashed (exit $crc: $(first_line "$c_.err"))"
    result="DIFFERENT (FAILURE: $why)"; n_diff=$((n_diff + 1))
  fi
  rows+=("| $name | $label | $disp | $mode | $result |")
done

if [[ -n $KEEP ]]; then
  rm -rf "$KEEP/current"
  cp -a "$CUR_OUT" "$KEEP/current"
fi

echo "Pixels of $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- 2>/dev/null || echo ' + uncommitted changes') against $BASE_REV ($BASE_SHA), $RES, $SPP spp, --threads $THREADS:"
echo
echo "| scene | integrator | dispersion | mode | result |"
echo "| --- | --- | --- | --- | --- |"
printf '%s\n' "${rows[@]}"
echo
log "total $((SECONDS - t_start)) s"
echo "$n_same identical, $n_diff different, $n_skip skipped"
((n_diff == 0 && n_same > 0))
