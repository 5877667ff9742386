#!/usr/bin/env bash
# How long the master takes to load a frame sequence at submission (docs/farm.md, "Frame
# sequences"; docs/performance.md): 10 frames (each its own camera) sharing one large binary PLY
# (bench_mesh_sphere: NU x NV segments, 2 x 1.0 M triangles by default), submitted to a master
# without workers, once with `--load-threads 1` (the frames one after another, each load on all
# the cores: the master before frames loaded in parallel) and once with the default (as many
# frames at once as cores, each load on its share), alternated REPS=3 times in one run. Prints
# each submission's load time as the master logs it ("scene ... loaded in X s": staging the
# bundle into the spool and loading every frame) and the best of each.
#   bash bench/load_frames.sh [--frames N] [--nu NU] [--nv NV] [--reps R]
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${PRISMFARM_BIN:-build/cli/prismfarm}
SPHERE=${BENCH_MESH_SPHERE:-build/bench/bench_mesh_sphere}
[[ -x $BIN && -x $SPHERE ]] ||
  { echo "bench/load_frames.sh: build first (bash deploy/build.sh release)" >&2; exit 1; }
FRAMES=10 NU=1000 NV=500 REPS=3
while [[ $# -gt 0 ]]; do
  case $1 in
    --frames) FRAMES=$2; shift 2 ;;
    --nu) NU=$2; shift 2 ;;
    --nv) NV=$2; shift 2 ;;
    --reps) REPS=$2; shift 2 ;;
    *) echo "load_frames.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
WORK=$(mktemp -d)
MASTER=
trap '[[ -n $MASTER ]] && kill "$MASTER" 2>/dev/null; rm -rf "$WORK"' EXIT
mkdir -p "$WORK/frames"
"$SPHERE" "$WORK/frames/mesh.ply" 1 "$NU" "$NV" >/dev/null
FILES=()
for ((k = 1; k <= FRAMES; k++)); do
  f=$(printf '%s/frames/f%04d.pbrt' "$WORK" "$k")
  cat > "$f" <<EOF
LookAt $(awk -v k="$k" 'BEGIN { printf "%.3f 0.5 -3.5", -1 + 2 * k / 10 }')  0 0 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "spectral" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
Sampler "independent" "integer pixelsamples" [ 1 ]
WorldBegin
LightSource "infinite" "rgb L" [ 0.5 0.5 0.5 ]
Material "diffuse"
Shape "plymesh" "string filename" "mesh.ply"
EOF
  FILES+=("$f")
done
echo "frames: $FRAMES sharing mesh.ply, $(du -m "$WORK/frames/mesh.ply" | cut -f1) MB," \
     "$((2 * NU * (NV - 1))) triangles; cores: $(nproc)"

# One submission to a fresh master with these options; prints the load time it logged.
load_once() {
  local spool="$WORK/spool$RANDOM" log="$WORK/master.log"
  rm -f "$log"
  "$BIN" master --workers "ipc://$spool-w.sock" --clients "ipc://$spool-c.sock" --spool "$spool" \
    --no-journal "$@" > "$log" 2>&1 &
  MASTER=$!
  for _ in $(seq 600); do grep -q "clients on" "$log" 2>/dev/null && break; sleep 0.1; done
  "$BIN" submit "${FILES[@]}" --master "ipc://$spool-c.sock" --timeout 600 > /dev/null 2> "$WORK/submit.err" \
    || { cat "$WORK/submit.err" >&2; exit 1; }
  kill "$MASTER"; wait "$MASTER" 2>/dev/null || true; MASTER=
  sed -n 's/.* loaded in \([0-9.]*\) s (off the loop).*/\1/p' "$log" | head -1
  rm -rf "$spool"
}

best_serial= best_par=
printf '%-6s %-26s %-26s\n' run "--load-threads 1 (s)" "default (s)"
for ((r = 1; r <= REPS; r++)); do
  s=$(load_once --load-threads 1)
  p=$(load_once)
  printf '%-6s %-26s %-26s\n' "$r" "$s" "$p"
  best_serial=$(awk -v a="$s" -v b="$best_serial" 'BEGIN { print (b == "" || a < b) ? a : b }')
  best_par=$(awk -v a="$p" -v b="$best_par" 'BEGIN { print (b == "" || a < b) ? a : b }')
done
awk -v s="$best_serial" -v p="$best_par" \
  'BEGIN { printf "best   %-26s %-26s ratio %.2f\n", s, p, s / p }'
