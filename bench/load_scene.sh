#!/usr/bin/env bash
# How long a large scene takes to load (issue 15, "Loading"): a scene of 800 binary PLY meshes
# (2 048 triangles each, 1.6 M in all) and four 1024x1024 PNG textures, generated here (python3,
# standard library only), loaded by `prismfarm render --direct` at 16x16 pixels and 1 spp, so
# that what is timed is the load (parse, PLY import, texture decode and RGB uplift, Embree
# build). Prints the wall and CPU seconds of the whole command, and of the same command on the
# scene without meshes and textures, for the difference.
#
# Then, side by side in the same run, `prismfarm render` through the farm in one process (its
# client, master and worker) against --direct, on that scene and on the corpus scene that takes
# longest to load (killeroo-gold at 16x16 pixels, when /work/shared/pbrt-scenes or $PBRT_SCENES is there): wall,
# CPU, peak memory, and how many times the process loaded the scene (the farm's "render: the
# scene was loaded N time(s) in this process and shared M time(s)" line; --direct loads once by
# construction). Before issue 15's shelf the farm loaded it three times.
#   bash bench/load_scene.sh [--keep DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${PRISMFARM_BIN:-build/cli/prismfarm}
[[ -x $BIN ]] || { echo "bench/load_scene.sh: build first (bash deploy/build.sh release)" >&2; exit 1; }
WORK=$(mktemp -d)
[[ ${1:-} == --keep ]] && WORK=$2 && mkdir -p "$WORK"
trap '[[ ${1:-} == --keep ]] || rm -rf "$WORK"' EXIT
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
for k in range(4):
    png(f"{work}/textures/t{k}.png", k)
head = ('LookAt 0 30 -40  0 0 0  0 1 0\nCamera "perspective" "float fov" [ 50 ]\n'
        'Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]\n'
        'Sampler "independent" "integer pixelsamples" [ 1 ]\nWorldBegin\n'
        'LightSource "distant" "point3 from" [ 0 10 0 ] "point3 to" [ 0 0 0 ]\n')
with open(f"{work}/empty.pbrt", "w") as f:
    f.write(head + 'Shape "sphere"\n')
with open(f"{work}/big.pbrt", "w") as f:
    f.write(head)
    for k in range(4):
        f.write(f'Texture "t{k}" "spectrum" "imagemap" "string filename" "textures/t{k}.png"\n')
    for m in range(800):
        ply(f"{work}/meshes/m{m}.ply", (m % 40) - 20, (m // 40) - 10)
        f.write(f'AttributeBegin\nMaterial "diffuse" "texture reflectance" "t{m % 4}"\n'
                f'Shape "plymesh" "string filename" "meshes/m{m}.ply"\nAttributeEnd\n')
PY
# timed SCENE LABEL [MODE [ARGS...]]: MODE --direct (default) or farm; ARGS go to render.
timed() {
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
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')"
echo "scene: 800 PLY meshes (1 638 400 triangles, $(du -sh "$WORK/meshes" | cut -f1)), 4 PNG textures 1024x1024"
timed "$WORK/empty.pbrt" "empty"
timed "$WORK/big.pbrt" "800 PLYs"
echo "farm in one process (client, master, worker) against --direct, side by side:"
timed "$WORK/big.pbrt" "800 PLYs --direct"
timed "$WORK/big.pbrt" "800 PLYs farm" farm
CORPUS=${PBRT_SCENES:-/work/shared/pbrt-scenes}
KG=$CORPUS/killeroos/killeroo-gold.pbrt
if [[ -f $KG ]]; then
  # At 16x16 pixels, so that what is timed is the load, as for the generated scene.
  timed "$KG" "killeroo-gold --direct" --direct --res 16x16
  timed "$KG" "killeroo-gold farm" farm --res 16x16
else
  echo "(no corpus at $CORPUS: killeroo-gold skipped)"
fi
