#!/usr/bin/env bash
# Real scenes against pbrt-v4 (docs/compatibility.md, "Real scenes against pbrt-v4"; issue 27):
# renders public pbrt-v4 scenes that stay outside the repository with pbrt-v4 and with prismfarm
# at a reduced size and equal spp, and says whether they match.
# For each scene of the list below (paths relative to --scenes; --only narrows it):
#   pbrt-v4   a copy of the file (in a temporary folder of links to the entries of the file's
#             folder, so that its relative paths resolve as beside the original) that changes only the
#             Film's xresolution / yresolution (longer side --res, aspect kept, as
#             ../shared/pbrt-scenes/reference/REFERENCE.md does) and adds "bool savefp16" [false],
#             rendered as `pbrt --nthreads 2 --spp N --seed S --outfile X.exr copy.pbrt` for
#             seeds 1 and 2; kept in --refs DIR (reused when they are there: pbrt-v4's images do
#             not change with prismfarm);
#   prismfarm `render FILE --res WxH --spp N --seed S --threads 2` with --direct for seeds 1 and
#             2, and seed 1 again in the default mode (the in-process farm), whose pixels must be
#             --direct's bit for bit, every channel ("farm = direct": yes / NO; the files differ
#             in the header's "prismfarm" attribute, which names the mode); kept in --ours DIR and reused
#             from there (empty it for another binary).
# Reported per scene: R/G/B mean ratios, ours over pbrt-v4's (both the mean of the two seeds),
# and a per-region check: the image cut into 4x4 regions, each region's R, G, B means compared
# as z = (ours - pbrt) / sqrt(se_ours^2 + se_pbrt^2), where a region mean's standard error comes
# from its 4x4-pixel blocks: var(block) = mean over blocks of (seed1 - seed2)^2 / 2 (two
# independent renders differ by sqrt 2 times either's noise; REFERENCE.md's 4x4 downsample),
# se^2 = var(block) / blocks / 2 (a region of that many blocks, averaged over two seeds).
# Verdict "match": every channel's mean within 2 % or 4 standard errors (the image's blocks, as a
# region's) and every region within 4 standard errors or
# 2 % (48 region-channel tests: at 4 sigma noise alone fails one scene in about 300);
# "mean only": means match, some region does not; "differs" otherwise; a refused render prints
# the first line of its message.
# Scenes (and each one's spp) are the list below; the scene files are the public ones, with the
# substitutes docs/compatibility.md lists where the public snapshots lack an asset.
# usage: bash bench/real_scenes.sh --scenes DIR --pbrt PBRT [--bin PRISMFARM] [--refs DIR]
#        [--ours DIR] [--res LONG] [--spp-scale F] [--only SUBSTRING] [--keep DIR]
#        [--skip-ours] [--skip-pbrt]
#        (defaults: build/cli/prismfarm, a temporary folder for --refs, 256, 1)
#   --spp-scale F  multiplies every scene's spp (e.g. 0.25 for a quick look)
#   --keep DIR     writes a PNG of each seed-1 image (ours and pbrt-v4's) into DIR to look at
#   --skip-ours    renders (or reuses) only pbrt-v4's references
#   --skip-pbrt    renders (or reuses) only ours (and checks farm = direct)
set -euo pipefail
cd "$(dirname "$0")/.."
scenes= pbrt= bin=build/cli/prismfarm refs= ours_dir= res=256 scale=1 only= keep= ours=1 with_pbrt=1
while [ $# -gt 0 ]; do
  case "$1" in
    --scenes) scenes=$2; shift 2 ;;
    --pbrt) pbrt=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --refs) refs=$2; shift 2 ;;
    --res) res=$2; shift 2 ;;
    --spp-scale) scale=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --keep) keep=$2; shift 2 ;;
    --ours) ours_dir=$2; shift 2 ;;
    --skip-ours) ours=0; shift ;;
    --skip-pbrt) with_pbrt=0; shift ;;
    -h|--help) sed -n '2,37p' "$0"; exit 0 ;;
    *) echo "real_scenes.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
# scene file (relative to --scenes) and its spp at scale 1
list=(
  "bmw-m6/bmw-m6.pbrt 16"
  "bmw-m6/bmw-m6-simple.pbrt 16"
  "sssdragon/dragon_50.pbrt 16"
  "hair/hair-eumel-2.pbrt 16"
  "measured/measured-sphere.pbrt 16"
  "disney-cloud/disney-cloud.pbrt 16"
  "volumetric-caustic/volumetric-caustic.pbrt 64"
)
[ -n "$scenes" ] && [ -d "$scenes" ] || { echo "real_scenes.sh: --scenes DIR (the folder holding the scene folders)" >&2; exit 2; }
((with_pbrt == 0)) || { [ -n "$pbrt" ] && [ -x "$pbrt" ]; } || { echo "real_scenes.sh: --pbrt BIN (a pbrt-v4 build)" >&2; exit 2; }
((ours == 0)) || [ -x "$bin" ] || { echo "real_scenes.sh: no $bin (build first, or --bin)" >&2; exit 2; }
[[ "$res" =~ ^[1-9][0-9]*$ ]] || { echo "real_scenes.sh: --res takes a positive integer" >&2; exit 2; }
[[ "$scale" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "real_scenes.sh: --spp-scale takes a number" >&2; exit 2; }
py=
for p in /usr/bin/python3 python3; do
  if "$p" -c 'import numpy, OpenImageIO' 2>/dev/null; then py=$p; break; fi
done
[ -n "$py" ] || { echo "real_scenes.sh: needs python3-numpy and python3-openimageio" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
[ -n "$refs" ] || refs=$tmp/refs
[ -n "$ours_dir" ] || ours_dir=$tmp/ours
mkdir -p "$refs" "$ours_dir"
[ -z "$keep" ] || mkdir -p "$keep"
scenes=$(realpath "$scenes") refs=$(realpath "$refs") ours_dir=$(realpath "$ours_dir")

# cpu_of OUT_VAR CMD...: runs CMD (output to $tmp/msg), sets OUT_VAR to its user + system seconds.
cpu_of() {
  local var=$1 t
  shift
  t=$( ("$@" >"$tmp/msg" 2>&1 || exit 1; times) | tail -1) || return 1
  printf -v "$var" '%s' "$(awk '{ for (i = 1; i <= 2; i++) { split($i, a, /[ms]/); t += a[1] * 60 + a[2] }
                                  printf "%.1f", t }' <<<"$t")"
}

# reduced_copy SCENE OUT LONG: OUT = SCENE with the Film's resolution's longer side LONG (aspect
# kept, the other side rounded) and 32-bit float EXR; prints WxH. pbrt-v4's defaults (1280x720)
# where the file gives none.
reduced_copy() {
  "$py" - "$1" "$2" "$3" <<'EOF'
import re, sys
src, out, long_side = sys.argv[1], sys.argv[2], int(sys.argv[3])
t = open(src).read()
def get(name, dflt):
    m = re.search(r'"integer\s+' + name + r'"\s*\[?\s*(\d+)', t)
    return int(m.group(1)) if m else dflt
x, y = get('xresolution', 1280), get('yresolution', 720)
if x >= y: nx, ny = long_side, max(1, round(y * long_side / x))
else: nx, ny = max(1, round(x * long_side / y)), long_side
m = re.search(r'Film\s+"[a-z]+"', t)
if not m: sys.exit(f'{src}: no Film statement')
def put(t, name, v):
    pat = r'("integer\s+' + name + r'"\s*)\[?\s*\d+\s*\]?'
    return re.sub(pat, lambda mm: mm.group(1) + f'[ {v} ]', t, count=1) if re.search(pat, t) else \
        t[:m.end()] + f' "integer {name}" [ {v} ]' + t[m.end():]
t = put(t, 'xresolution', nx)
m = re.search(r'Film\s+"[a-z]+"', t)
t = put(t, 'yresolution', ny)
m = re.search(r'Film\s+"[a-z]+"', t)
t = t[:m.end()] + ' "bool savefp16" [ false ]' + t[m.end():]
open(out, 'w').write(t)
print(f'{nx}x{ny}')
EOF
}

compare() { # compare OURS1 OURS2 PBRT1 PBRT2: prints "ratios|worst region|verdict"
  "$py" - "$@" <<'EOF'
import sys, numpy as np, OpenImageIO as oiio
def rgb(p):
    b = oiio.ImageBuf(p)
    if b.has_error: sys.exit(f'{p}: {b.geterror()}')
    n = list(b.spec().channelnames)
    a = np.asarray(b.get_pixels(oiio.FLOAT), dtype=np.float64)
    return a[:, :, [n.index(c) for c in 'RGB']]
o1, o2, p1, p2 = (rgb(p) for p in sys.argv[1:5])
if o1.shape != p1.shape: sys.exit(f'size {o1.shape[1]}x{o1.shape[0]} differs from pbrt-v4 {p1.shape[1]}x{p1.shape[0]}')
h, w = o1.shape[0] // 16 * 16, o1.shape[1] // 16 * 16
def blocks(a):  # 4x4-pixel block means, shape (H/4, W/4, 3)
    return a[:h, :w].reshape(h // 4, 4, w // 4, 4, 3).mean(axis=(1, 3))
def regions(b):  # 4x4 regions of blocks: (4, 4, n_blocks, 3)
    bh, bw = b.shape[0] // 4, b.shape[1] // 4
    return b.reshape(4, bh, 4, bw, 3).transpose(0, 2, 1, 3, 4).reshape(4, 4, bh * bw, 3)
def stats(a1, a2):
    r1, r2 = regions(blocks(a1)), regions(blocks(a2))
    mean = (r1.mean(axis=2) + r2.mean(axis=2)) / 2
    var_block = ((r1 - r2) ** 2 / 2).mean(axis=2)
    return mean, var_block / r1.shape[2] / 2
mo, vo = stats(o1, o2)
mp, vp = stats(p1, p2)
ratio = ((o1 + o2) / 2).mean(axis=(0, 1)) / ((p1 + p2) / 2).mean(axis=(0, 1))
z = (mo - mp) / np.sqrt(vo + vp + 1e-300)
rel = np.abs(mo - mp) / np.maximum(np.abs(mp), 1e-12)
bad = (np.abs(z) > 4) & (rel > 0.02)
# the worst region: the largest |z| among those off by over 2 %, else the largest relative difference
i = np.unravel_index(np.argmax(np.where(bad, np.abs(z), 0)) if bad.any() else np.argmax(rel), z.shape)
worst = f'{bad.any(axis=2).sum()} of 16 regions off; worst row {i[0]} col {i[1]} {"RGB"[i[2]]}: ' \
        f'ours/pbrt {mo[i] / mp[i] if mp[i] else float("inf"):.3f}, z {z[i]:+.1f}'
# the image mean's own noise, as a region's (every block of the image): a light smaller than a
# pixel seen directly (volumetric-caustic's 5 mm quad) puts a few samples of radiance 5e5 in one
# pixel, the seeds differ by half the image's mean in either renderer, and only z says so
def image_z():
    def one(a1, a2):
        b1, b2 = blocks(a1).reshape(-1, 3), blocks(a2).reshape(-1, 3)
        return (b1.mean(axis=0) + b2.mean(axis=0)) / 2, ((b1 - b2) ** 2 / 2).mean(axis=0) / b1.shape[0] / 2
    (m1, v1), (m2, v2) = one(o1, o2), one(p1, p2)
    return (m1 - m2) / np.sqrt(v1 + v2 + 1e-300)
zi = image_z()
means_ok = bool(((np.abs(ratio - 1) <= 0.02) | (np.abs(zi) <= 4)).all())
verdict = 'match' if means_ok and not bad.any() else ('mean only' if means_ok else 'differs')
print(f'{ratio[0]:.4f} / {ratio[1]:.4f} / {ratio[2]:.4f}|{worst}|{verdict}')
EOF
}

same_pixels() { # same_pixels A.exr B.exr: every channel's pixels bit for bit (the EXR header's
  # "prismfarm" attribute says how each was made, so the files' bytes differ)
  "$py" - "$1" "$2" <<'EOF'
import sys, numpy as np, OpenImageIO as oiio
a, b = oiio.ImageBuf(sys.argv[1]), oiio.ImageBuf(sys.argv[2])
if list(a.spec().channelnames) != list(b.spec().channelnames): sys.exit(1)
A = np.asarray(a.get_pixels(oiio.FLOAT)); B = np.asarray(b.get_pixels(oiio.FLOAT))
sys.exit(0 if A.shape == B.shape and A.view(np.uint32).tobytes() == B.view(np.uint32).tobytes() else 1)
EOF
}

png_of() { # png_of EXR PNG: a tone-mapped (clamp, sRGB) PNG to look at
  "$py" - "$1" "$2" <<'EOF' || true
import sys, numpy as np, OpenImageIO as oiio
b = oiio.ImageBuf(sys.argv[1]); n = list(b.spec().channelnames)
a = np.asarray(b.get_pixels(oiio.FLOAT), dtype=np.float64)[:, :, [n.index(c) for c in 'RGB']]
a = np.clip(a, 0, 1); a = np.where(a <= 0.0031308, 12.92 * a, 1.055 * a ** (1 / 2.4) - 0.055)
o = oiio.ImageBuf(oiio.ImageSpec(a.shape[1], a.shape[0], 3, oiio.UINT8))
o.set_pixels(oiio.ROI(0, a.shape[1], 0, a.shape[0], 0, 1, 0, 3), np.ascontiguousarray(a, dtype=np.float32))
o.write(sys.argv[2])
EOF
}

echo "Real scenes against pbrt-v4: $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores, 2 threads, longer side $res px, seeds 1 and 2"
echo "pbrt-v4: $pbrt; prismfarm: $bin ($(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
echo "load before: $(uptime)"
echo
echo "| scene | size | spp | pbrt-v4 CPU s | ours CPU s (direct) | farm = direct | mean ratio R / G / B | regions (4x4) | verdict |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for entry in "${list[@]}"; do
  rel=${entry% *} spp0=${entry##* }
  case "$rel" in *"$only"*) ;; *) continue ;; esac
  spp=$(awk -v s="$spp0" -v f="$scale" 'BEGIN { n = int(s * f + 0.5); print n < 1 ? 1 : n }')
  scene=$scenes/$rel
  tag=$(tr / _ <<<"${rel%.pbrt}")
  if [ ! -f "$scene" ]; then
    echo "| $rel | - | $spp | - | - | - | - | - | no scene file |"
    continue
  fi
  # A reduced copy in a folder of links to the scene folder's entries (relative paths resolve).
  mirror=$tmp/mirror/$(dirname "$rel")
  mkdir -p "$mirror"
  for e in "$(dirname "$scene")"/*; do ln -sfn "$(realpath "$e")" "$mirror/"; done
  copy=$mirror/.real_scenes_$(basename "$scene")
  size=$(reduced_copy "$scene" "$copy" "$res") || {
    echo "| $rel | - | $spp | - | - | - | - | - | cannot reduce: $size |"; continue; }
  stem=${tag}__${size}__spp${spp}
  # Ours: --direct seeds 1 and 2, then the farm's seed 1 (its bytes against --direct's).
  ocpu=- same=- ofail=
  if ((ours)); then
    for s in 1 2; do
      if [ -f "$ours_dir/${stem}__s$s.exr" ]; then ocpu=kept; continue; fi
      if ! cpu_of c "$bin" render "$scene" --res "$size" --spp "$spp" --threads 2 --quiet --seed "$s" \
        --direct -o "$tmp/d.exr"; then
        ofail="refused (--direct): $(grep -iv warning "$tmp/msg" | grep . | head -1)"; break
      fi
      mv "$tmp/d.exr" "$ours_dir/${stem}__s$s.exr"
      [ "$ocpu" != - ] || ocpu=$c
      echo "$rel seed $s: prismfarm render --direct --res $size --spp $spp --seed $s --threads 2: $c CPU s" >>"$ours_dir/COMMANDS.txt"
    done
    if [ -z "$ofail" ]; then
      if [ -f "$ours_dir/${stem}__farm.txt" ]; then same=$(cat "$ours_dir/${stem}__farm.txt")
      else
        if ! "$bin" render "$scene" --res "$size" --spp "$spp" --threads 2 --quiet --seed 1 \
          -o "$tmp/f.exr" >"$tmp/msg" 2>&1; then
          same="refused: $(grep -iv warning "$tmp/msg" | grep . | head -1)"
        elif same_pixels "$ours_dir/${stem}__s1.exr" "$tmp/f.exr"; then same=yes
        else same=NO
        fi
        echo "$same" >"$ours_dir/${stem}__farm.txt"
      fi
      [ -z "$keep" ] || png_of "$ours_dir/${stem}__s1.exr" "$keep/${tag}__ours.png"
    fi
  fi
  # pbrt-v4: seeds 1 and 2.
  pcpu=- pfail=
  if ((with_pbrt)); then
    for s in 1 2; do
      ref=$refs/${stem}__s$s.exr
      if [ -f "$ref" ]; then pcpu=kept; continue; fi
      if cpu_of c "$pbrt" --nthreads 2 --spp "$spp" --seed "$s" --outfile "$tmp/p.exr" "$copy"; then
        mv "$tmp/p.exr" "$ref"
        [ "$pcpu" != - ] || pcpu=$c
        echo "$rel seed $s: pbrt --nthreads 2 --spp $spp --seed $s --outfile $(basename "$ref") <copy at $size, savefp16 false>: $c CPU s" >>"$refs/COMMANDS.txt"
      else
        pfail="pbrt-v4 refused: $(grep -iv warning "$tmp/msg" | grep . | tail -1)"; break
      fi
    done
    [ -n "$pfail" ] || [ -z "$keep" ] || png_of "$refs/${stem}__s1.exr" "$keep/${tag}__pbrt.png"
  fi
  rm -f "$copy"
  if [ -n "$ofail$pfail" ]; then
    echo "| $rel | $size | $spp | $pcpu | $ocpu | $same | - | - | ${ofail:-$pfail} |"
  elif ((ours == 0 || with_pbrt == 0)); then
    echo "| $rel | $size | $spp | $pcpu | $ocpu | $same | - | - | $( ((ours)) && echo 'ours only' || echo 'pbrt-v4 only') |"
  elif out=$(compare "$ours_dir/${stem}__s1.exr" "$ours_dir/${stem}__s2.exr" "$refs/${stem}__s1.exr" \
    "$refs/${stem}__s2.exr" 2>&1); then
    IFS='|' read -r ratio regions verdict <<<"$out"
    [ "$same" = yes ] || verdict="$verdict (farm: $same)"
    echo "| $rel | $size | $spp | $pcpu | $ocpu | $same | $ratio | $regions | **$verdict** |"
  else
    echo "| $rel | $size | $spp | $pcpu | $ocpu | $same | - | - | compare failed: $out |"
  fi
done
echo
echo "load after: $(uptime)"
