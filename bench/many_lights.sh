#!/bin/bash
# A scene of many small emissive triangles (64 lamps of 80 triangles each: 5120 emitters, of
# very different brightness, over a diffuse floor with a few boxes), rendered under
# `"string lightsampler"` "bvh" and "power" at the same spp with seeds 1 and 2: CPU seconds
# per image and the relative variance between the seeds (the noise figure of
# ../shared/tools/equal_error.py), so the light BVH's cost with thousands of emitters and its
# gain can be read side by side. A benchmark, not a test: the times depend on the machine.
# usage: bash bench/many_lights.sh [--spp N] [--bin PRISMFARM]
set -euo pipefail
spp=16 bin=build/cli/prismfarm py=${PYTHON:-/usr/bin/python3}  # numpy and OpenImageIO
while [ $# -gt 0 ]; do
  case "$1" in
    --spp) spp=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    *) echo "usage: bash bench/many_lights.sh [--spp N] [--bin PRISMFARM]" >&2; exit 2 ;;
  esac
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 - "$tmp" <<'PY'
import math, sys
out = sys.argv[1]
def lamp(cx, cy, cz, r, L, nu=8, nv=5):
    P, I = [], []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu):
            ph = 2 * math.pi * i / nu
            P += [cx + r * math.sin(th) * math.cos(ph), cy + r * math.cos(th), cz + r * math.sin(th) * math.sin(ph)]
    for j in range(nv):
        for i in range(nu):
            a, b = j * nu + i, j * nu + (i + 1) % nu
            I += [a, b, a + nu, b, b + nu, a + nu]
    return ('AttributeBegin\nAreaLightSource "diffuse" "rgb L" [%g %g %g]\n'
            'Shape "trianglemesh" "point3 P" [%s] "integer indices" [%s]\nAttributeEnd\n'
            % (L[0], L[1], L[2], ' '.join('%.6f' % x for x in P), ' '.join(map(str, I))))
for ls in ('bvh', 'power'):
    with open('%s/%s.pbrt' % (out, ls), 'w') as f:
        f.write('LookAt 0 6 -9  0 0 0  0 1 0\nCamera "perspective" "float fov" 45\n'
                'Film "rgb" "integer xresolution" 256 "integer yresolution" 192\n'
                'Sampler "independent"\nIntegrator "path" "integer maxdepth" 5 "string lightsampler" "%s"\n'
                'WorldBegin\n' % ls)
        k = 0
        for gx in range(8):
            for gz in range(8):
                x, z = -7 + 2 * gx, -7 + 2 * gz
                bright = 40.0 if (gx * 3 + gz * 5) % 11 == 0 else 2.0
                f.write(lamp(x + 0.3 * math.sin(k), 0.6 + 0.4 * ((gx + gz) % 3), z, 0.12, (bright, bright * 0.8, bright * 0.6), nu=8, nv=5))
                k += 1
        f.write('Material "diffuse" "rgb reflectance" [0.6 0.6 0.6]\n'
                'Shape "trianglemesh" "integer indices" [0 1 2 0 2 3] "point3 P" [-12 0 -12  12 0 -12  12 0 12  -12 0 12]\n')
        for bx, bz in ((-3, 1), (2, -2), (4, 4)):
            f.write('AttributeBegin\nTranslate %g 0.75 %g\nShape "trianglemesh" "integer indices" '
                    '[0 1 2 0 2 3 4 6 5 4 7 6 0 4 5 0 5 1 1 5 6 1 6 2 2 6 7 2 7 3 3 7 4 3 4 0] "point3 P" '
                    '[-0.75 -0.75 -0.75 0.75 -0.75 -0.75 0.75 0.75 -0.75 -0.75 0.75 -0.75 '
                    '-0.75 -0.75 0.75 0.75 -0.75 0.75 0.75 0.75 0.75 -0.75 0.75 0.75]\nAttributeEnd\n' % (bx, bz))
PY
echo "| lightsampler | emissive triangles | CPU s per image | relative variance | efficiency (1 / (var x CPU)) |"
echo "| --- | --- | --- | --- | --- |"
for ls in bvh power; do
  cpu=0
  for s in 1 2; do
    /usr/bin/time -f "%U %S" -o "$tmp/t" "$bin" render "$tmp/$ls.pbrt" --direct --spp "$spp" --seed $s \
      --threads 2 -o "$tmp/$ls.$s.exr" --quiet >/dev/null
    cpu=$(awk -v c="$cpu" '{ print c + $1 + $2 }' "$tmp/t")
  done
  "$py" - "$tmp/$ls.1.exr" "$tmp/$ls.2.exr" "$cpu" "$ls" <<'PY'
import sys
import numpy as np, OpenImageIO as oiio
def rgb(p):
    b = oiio.ImageBuf(p); n = list(b.spec().channelnames)
    a = np.asarray(b.get_pixels(oiio.FLOAT), dtype=np.float64)
    return a[:, :, [n.index(c) for c in 'RGB']]
def down4(a):
    h, w = a.shape[0] // 4 * 4, a.shape[1] // 4 * 4
    return a[:h, :w].reshape(h // 4, 4, w // 4, 4, 3).mean(axis=(1, 3))
a, b = rgb(sys.argv[1]), rgb(sys.argv[2])
d = down4(a) - down4(b)
rv = (d * d / 2).mean() / ((a + b) / 2).mean() ** 2
cpu = float(sys.argv[3]) / 2
print('| %s | 5120 | %.1f | %.3e | %.3g |' % (sys.argv[4], cpu, rv, 1 / (rv * cpu)))
PY
done
