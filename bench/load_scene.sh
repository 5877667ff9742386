#!/usr/bin/env bash
# How long a large scene takes to load (issue 15, "Loading": "a scene with 800 PLY meshes and
# 1024x1024 textures loads in seconds, not minutes"): a scene of 800 binary PLY meshes (2 048
# triangles each, 1.6 M in all), four 1024x1024 PNG and two 1024x1024 OpenEXR textures,
# generated here in a temporary folder (python3, standard library only), loaded by
# `prismfarm render --direct` at 16x16 pixels and 1 spp, so that what is timed is the load
# (parse, PLY import, texture decoding and RGB uplift, Embree build). Prints, side by side in
# one run, the wall and CPU seconds and the peak resident memory of the whole command on one
# core (taskset -c 0: the loader's pool and Embree's build threads follow the process's CPU
# affinity) and on all the cores the process may use (each the best of REPS=3 runs), then the same for the scene without
# meshes and textures (the command's own cost), and checks that both loads render the same
# pixels (bench_exr_pixels). Then, when the pbrt-v4 corpus is there (../shared/pbrt-scenes
# beside the clone, or CORPUS=DIR), the five of its scenes that take longest to load, timed the
# same way (16x16, 1 spp, --integrator path so that no photon pass is timed) on 1 core and on all.
# With --before BIN, the large scene is timed with that (an earlier revision's) prismfarm too,
# in the same run. Then, side by side, `prismfarm render` through the farm in one process (its
# client, master and worker) against --direct, on the generated scene and on killeroo-gold at
# 16x16 (when the corpus is there): wall, CPU, peak memory, and how many times the process
# loaded the scene (the farm's "render: the scene was loaded N time(s) in this process and
# shared M time(s)" line; --direct loads once by construction; before issue 15's shelf the farm
# loaded it three times).
#   bash bench/load_scene.sh [--keep DIR] [--before BIN]
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${PRISMFARM_BIN:-build/cli/prismfarm}
[[ -x $BIN ]] || { echo "bench/load_scene.sh: build first (bash deploy/build.sh release)" >&2; exit 1; }
WORK=$(mktemp -d)
KEEP= BEFORE=
while [[ $# -gt 0 ]]; do
  case $1 in
    --keep) rm -rf "$WORK"; WORK=$2 KEEP=1; mkdir -p "$WORK"; shift 2 ;;
    --before) BEFORE=$2; shift 2 ;;
    *) echo "load_scene.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done
trap '[[ -n $KEEP ]] || rm -rf "$WORK"' EXIT
PIXELS=${BENCH_EXR_PIXELS:-build/bench/bench_exr_pixels}
CORPUS=${CORPUS:-../shared/pbrt-scenes}
python3 - "$WORK" <<'PY'
import math, os, struct, sys, zlib
work = sys.argv[1]
os.makedirs(f"{work}/meshes", exist_ok=True)
os.makedirs(f"{work}/textures", exist_ok=True)
N = 32  # a 32x32 grid of quads: 1089 vertices, 2048 triangles
def ply(path, ox, oz):
    verts = [(ox + i / N, 0.05 * math.sin(i + j), oz + j / N, i / N, j / N)
             for j in range(N + 1) for i in range(N + 1)]
    faces = []
    for j in range(N):
        for i in range(N):
            a = j * (N + 1) + i
            faces += [(a, a + 1, a + N + 2), (a, a + N + 2, a + N + 1)]
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\n"
                 f"element vertex {len(verts)}\nproperty float x\nproperty float y\n"
                 "property float z\nproperty float u\nproperty float v\n"
                 f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
                 "end_header\n").encode())
        for v in verts:
            f.write(struct.pack("<5f", *v))
        for t in faces:
            f.write(struct.pack("<B3i", 3, *t))
def png(path, seed):
    w = h = 1024
    rows = bytearray()
    for y in range(h):
        rows.append(0)
        rows += bytes(((x * 7 + y * 3 + seed * 50) & 255, (x ^ y) & 255, (y * 5 + seed) & 255)
                      [c] for x in range(w) for c in range(3))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(bytes(rows), 6)) + chunk(b"IEND", b""))
def exr(path, seed):
    # Uncompressed scanline OpenEXR (the file format's version 2, single part), FLOAT B, G, R.
    w = h = 1024
    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value
    chans = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<4i", 0, 0, w - 1, h - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + attr("channels", "chlist", chans)
              + attr("compression", "compression", b"\0") + attr("dataWindow", "box2i", box)
              + attr("displayWindow", "box2i", box) + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    row_bytes = 3 * 4 * w
    first = len(header) + 8 * h
    offsets = b"".join(struct.pack("<Q", first + y * (8 + row_bytes)) for y in range(h))
    with open(path, "wb") as f:
        f.write(header + offsets)
        for y in range(h):
            r = [((x * 3 + y + seed * 90) % 256) / 255.0 for x in range(w)]
            g = [((x ^ (y + seed)) % 256) / 300.0 for x in range(w)]
            b = [((y * 2 + seed * 40) % 256) / 255.0 for x in range(w)]
            f.write(struct.pack("<ii", y, row_bytes) + struct.pack(f"<{w}f", *b)
                    + struct.pack(f"<{w}f", *g) + struct.pack(f"<{w}f", *r))
for k in range(4):
    png(f"{work}/textures/t{k}.png", k)
for k in range(4, 6):
    exr(f"{work}/textures/t{k}.exr", k)
head = ('LookAt 0 30 -40  0 0 0  0 1 0\nCamera "perspective" "float fov" [ 50 ]\n'
        'Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]\n'
        'Sampler "independent" "integer pixelsamples" [ 1 ]\nWorldBegin\n'
        'LightSource "distant" "point3 from" [ 0 10 0 ] "point3 to" [ 0 0 0 ]\n')
with open(f"{work}/empty.pbrt", "w") as f:
    f.write(head + 'Shape "sphere"\n')
with open(f"{work}/big.pbrt", "w") as f:
    f.write(head)
    for k in range(6):
        f.write(f'Texture "t{k}" "spectrum" "imagemap" "string filename" '
                f'"textures/t{k}.{"png" if k < 4 else "exr"}"\n')
    for m in range(800):
        ply(f"{work}/meshes/m{m}.ply", (m % 40) - 20, (m // 40) - 10)
        f.write(f'AttributeBegin\nMaterial "diffuse" "texture reflectance" "t{m % 6}"\n'
                f'Shape "plymesh" "string filename" "meshes/m{m}.ply"\nAttributeEnd\n')
PY
# timed LABEL SCENE OUT [taskset args...]: one load, the best of REPS runs (the machine is
# shared: the fastest run is the one least slowed by others): its wall and CPU seconds and
# peak memory; WALL is left set to its wall seconds.
REPS=${REPS:-3}
timed() {
  local label=$1 scene=$2 out=$3 t0 t1 w best= cpu rss
  shift 3
  for ((r = 0; r < REPS; r++)); do
    t0=$(date +%s.%N)
    "$@" /usr/bin/time -f "%U %S %M" -o "$WORK/time" "$BIN" render "$scene" --direct --spp 1 \
      --res 16x16 --integrator path -o "$out" --quiet >/dev/null 2>&1 ||
      { echo "$label: prismfarm render failed" >&2; return 1; }
    t1=$(date +%s.%N)
    read -r user sys peak <"$WORK/time"
    w=$(echo "$t1 - $t0" | bc)
    if [[ -z $best ]] || (($(echo "$w < $best" | bc))); then
      best=$w cpu=$(echo "$user + $sys" | bc) rss=$peak
    fi
  done
  WALL=$best
  printf '%-42s wall %6.2f s  cpu %6.2f s  peak %5d MB\n' "$label" "$WALL" "$cpu" $((rss / 1024))
}
cores=$(nproc)
echo "machine: $cores cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), load average $(cut -d' ' -f1 /proc/loadavg)"
echo "scene: 800 PLY meshes (1 638 400 triangles, $(du -sh "$WORK/meshes" | cut -f1)), 4 PNG + 2 EXR textures 1024x1024 ($(du -sh "$WORK/textures" | cut -f1))"
timed "empty, 1 core" "$WORK/empty.pbrt" "$WORK/e1.exr" taskset -c 0
timed "empty, $cores cores" "$WORK/empty.pbrt" "$WORK/e.exr"
if [[ -n $BEFORE ]]; then
  NOW=$BIN BIN=$BEFORE
  timed "before: 800 PLYs + 6 textures, 1 core" "$WORK/big.pbrt" "$WORK/b1.exr" taskset -c 0
  timed "before: 800 PLYs + 6 textures, $cores cores" "$WORK/big.pbrt" "$WORK/b.exr"
  BIN=$NOW
fi
timed "800 PLYs + 6 textures, 1 core" "$WORK/big.pbrt" "$WORK/one.exr" taskset -c 0
one=$WALL
timed "800 PLYs + 6 textures, $cores cores" "$WORK/big.pbrt" "$WORK/all.exr"
printf 'wall time, 1 core / %d cores: %.2f\n' "$cores" "$(echo "$one / $WALL" | bc -l)"
if [[ -x $PIXELS ]]; then
  "$PIXELS" compare "$WORK/one.exr" "$WORK/all.exr" >/dev/null &&
    echo "same pixels on 1 and $cores cores" || { echo "DIFFERENT pixels on 1 and $cores cores"; exit 1; }
fi
# timed_mode SCENE LABEL [MODE [ARGS...]]: MODE --direct (default) or farm; ARGS go to render.
timed_mode() {
  local t0 t1 mode=${3:---direct} loads="" args=(--quiet)
  [[ $mode == farm ]] && mode="" && args=()
  args+=("${@:4}")
  t0=$(date +%s.%N)
  /usr/bin/time -f "%U %S %M" -o "$WORK/time" "$BIN" render "$1" $mode --spp 1 -o "$WORK/out.exr" \
    "${args[@]}" >/dev/null 2>"$WORK/err"
  t1=$(date +%s.%N)
  read -r user sys rss <"$WORK/time"
  if [[ -z $mode ]]; then
    loads=$(sed -n 's/.*the scene was loaded \([0-9]*\) times\{0,1\} in this process and shared \([0-9]*\).*/  loads \1, shared \2/p' "$WORK/err")
    [[ -n $loads ]] || loads="  loads ? (no count printed)"
  else
    loads="  loads 1"
  fi
  printf '%-24s wall %6.2f s  cpu %6.2f s  peak %5d MB%s\n' "$2" "$(echo "$t1 - $t0" | bc)" \
    "$(echo "$user + $sys" | bc)" $((rss / 1024)) "$loads"
}
echo "farm in one process (client, master, worker) against --direct, side by side:"
timed_mode "$WORK/big.pbrt" "800 PLYs --direct"
timed_mode "$WORK/big.pbrt" "800 PLYs farm" farm
KG=$CORPUS/killeroos/killeroo-gold.pbrt
if [[ -f $KG ]]; then
  # At 16x16 pixels, so that what is timed is the load, as for the generated scene.
  timed_mode "$KG" "killeroo-gold --direct" --direct --res 16x16
  timed_mode "$KG" "killeroo-gold farm" farm --res 16x16
else
  echo "(no corpus at $CORPUS: killeroo-gold skipped)"
fi
[[ -d $CORPUS/reference ]] || exit 0
echo "corpus ($CORPUS): the five slowest loads"
for ref in "$CORPUS"/reference/*__*.exr; do # the scenes with a reference, as corpus.sh
  base=${ref##*/} base=${base%.exr}
  scene="$CORPUS/${base%%__*}/${base#*__}.pbrt"
  [[ -f $scene ]] || continue
  name=${scene#"$CORPUS"/}
  timed "$name, 1 core" "$scene" "$WORK/c1.exr" taskset -c 0 >"$WORK/row1" || continue
  w1=$WALL
  timed "$name, $cores cores" "$scene" "$WORK/c.exr" >"$WORK/row" || continue
  printf '%s\t%s\t%s\n' "$w1" "$(cat "$WORK/row1")" "$(cat "$WORK/row")"
done | sort -rn | head -5 | cut -f2,3 | tr '\t' '\n'
