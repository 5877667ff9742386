#!/usr/bin/env python3
"""Generates scenes/calcite.pbrt's pieces: the printed page (scenes/images/calcite_text.png, a
160 x 112 8-bit sRGB PNG of four lines of capitals in a 5 x 7 bitmap font, each underlined by a
thin rule, black ink on off-white paper) and the cleavage rhomb of calcite
(scenes/geometry/calcite_rhomb.pbrt: a mesh and its optic axis).

The rhomb: calcite cleaves along {10-11} into a rhombohedron whose faces are rhombi of angles
101.9 and 78.1 degrees (Hecht, Optics, 4th ed. sec. 8.4.1; the blunt corners join three obtuse
angles). Its three edges from a blunt corner are unit vectors a_i at equal angles alpha from
the optic axis c (the three-fold axis through the blunt corners), a_i . a_j = cos 101.9 deg,
so 1 - 1.5 sin^2 alpha = cos 101.9 deg. It rests on the face (a_1, a_2) on the page, turned
about the vertical; the optic axis then makes about 45 degrees with the face normal (44.6 in
Hecht), the walk-off is about 6.2 degrees and the two images lie h tan(6.2 deg) apart, h the
rhomb's height. Only the standard library. Run from the repository root:
python3 tools/gen_calcite.py
"""
import math
import os
import struct
import zlib

ROOT = os.path.join(os.path.dirname(__file__), "..")

FONT = {  # 5 x 7, rows top to bottom, '#' ink
    "A": [" ### ", "#   #", "#   #", "#####", "#   #", "#   #", "#   #"],
    "B": ["#### ", "#   #", "#   #", "#### ", "#   #", "#   #", "#### "],
    "C": [" ####", "#    ", "#    ", "#    ", "#    ", "#    ", " ####"],
    "D": ["#### ", "#   #", "#   #", "#   #", "#   #", "#   #", "#### "],
    "E": ["#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#####"],
    "F": ["#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#    "],
    "I": ["#####", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", "#####"],
    "L": ["#    ", "#    ", "#    ", "#    ", "#    ", "#    ", "#####"],
    "M": ["#   #", "## ##", "# # #", "# # #", "#   #", "#   #", "#   #"],
    "N": ["#   #", "##  #", "# # #", "#  ##", "#   #", "#   #", "#   #"],
    "O": [" ### ", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "],
    "P": ["#### ", "#   #", "#   #", "#### ", "#    ", "#    ", "#    "],
    "R": ["#### ", "#   #", "#   #", "#### ", "# #  ", "#  # ", "#   #"],
    "S": [" ####", "#    ", "#    ", " ### ", "    #", "    #", "#### "],
    "T": ["#####", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", "  #  "],
    "U": ["#   #", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "],
    " ": ["     "] * 7,
}
LINES = ["ICELAND SPAR", "DOUBLE", "REFRACTION", "CALCITE"]
W, H, SCALE = 160, 112, 2


def write_png(path, w, h, grey):
    """grey(x, y) -> linear value in [0, 1], y = 0 the top row; stored sRGB-encoded RGB."""

    def encode(v):
        v = min(1.0, max(0.0, v))
        s = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
        return int(round(255 * s))

    raw = bytearray()
    for y in range(h):
        raw.append(0)
        for x in range(w):
            raw.extend([encode(grey(x, y))] * 3)

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(bytes(raw), 9)))
        f.write(chunk(b"IEND", b""))


def page():
    ink = [[False] * W for _ in range(H)]
    line_h = 7 * SCALE + 12
    top = (H - len(LINES) * line_h) // 2 + 3
    for li, text in enumerate(LINES):
        width = len(text) * 6 * SCALE - SCALE
        x0 = (W - width) // 2
        y0 = top + li * line_h
        for ci, ch in enumerate(text):
            glyph = FONT[ch]
            for gy in range(7):
                for gx in range(5):
                    if glyph[gy][gx] == "#":
                        for sy in range(SCALE):
                            for sx in range(SCALE):
                                ink[y0 + gy * SCALE + sy][x0 + ci * 6 * SCALE + gx * SCALE + sx] = True
        rule = y0 + 7 * SCALE + 3
        for x in range(8, W - 8):
            ink[rule][x] = True
    write_png(os.path.join(ROOT, "scenes", "images", "calcite_text.png"), W, H,
              lambda x, y: 0.03 if ink[y][x] else 0.8)


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def add(a, b):
    return [a[i] + b[i] for i in range(3)]


def scale(a, s):
    return [a[i] * s for i in range(3)]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    return scale(a, 1 / math.sqrt(dot(a, a)))


def rhomb(edge=3.0, turn_deg=25.0):
    cos_face = math.cos(math.radians(101.9))
    sin_a = math.sqrt((1 - cos_face) / 1.5)
    cos_a = math.sqrt(1 - sin_a * sin_a)
    a = [[sin_a * math.cos(p), sin_a * math.sin(p), cos_a] for p in (0, 2 * math.pi / 3, 4 * math.pi / 3)]
    c = [0.0, 0.0, 1.0]
    # The bottom face (a1, a2): its outward normal points away from a3.
    nb = norm(cross(a[0], a[1]))
    if dot(nb, a[2]) > 0:
        nb = scale(nb, -1)
    up = scale(nb, -1)
    ex = norm(sub(a[0], scale(up, dot(a[0], up))))
    ez = cross(ex, up)
    t = math.radians(turn_deg)

    def world(v):
        x, y, z = dot(v, ex), dot(v, up), dot(v, ez)
        return [math.cos(t) * x + math.sin(t) * z, y, -math.sin(t) * x + math.cos(t) * z]

    corners = []
    for i in range(8):
        v = [0.0, 0.0, 0.0]
        for k in range(3):
            if i >> k & 1:
                v = add(v, scale(a[k], edge))
        corners.append(world(v))
    centre = scale([sum(p[i] for p in corners) for i in range(3)], 1 / 8)
    lift = -min(p[1] for p in corners) + 0.002
    corners = [[p[0] - centre[0], p[1] + lift, p[2] - centre[2]] for p in corners]
    centre = scale([sum(p[i] for p in corners) for i in range(3)], 1 / 8)
    faces = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    tris = []
    for f in faces:
        for tri in ((f[0], f[1], f[2]), (f[0], f[2], f[3])):
            p0, p1, p2 = (corners[i] for i in tri)
            n = cross(sub(p1, p0), sub(p2, p0))
            if dot(n, sub(p0, centre)) < 0:
                tri = (tri[0], tri[2], tri[1])
            tris.append(tri)
    axis = world(c)
    height = max(p[1] for p in corners) - min(p[1] for p in corners)
    angle = math.degrees(math.acos(abs(dot(axis, [0, 1, 0]))))
    return corners, tris, axis, height, angle


def main():
    page()
    corners, tris, axis, height, angle = rhomb()
    path = os.path.join(ROOT, "scenes", "geometry", "calcite_rhomb.pbrt")
    with open(path, "w") as f:
        f.write("# A cleavage rhomb of calcite (edges 3, face angles 101.9 / 78.1 degrees) resting on a\n")
        f.write("# face at y = 0.002; generated by tools/gen_calcite.py. Its optic axis (the three-fold\n")
        f.write("# axis through the blunt corners) makes %.1f degrees with the vertical; height %.3f.\n"
                % (angle, height))
        f.write('Material "uniaxial" "string crystal" "calcite"\n')
        f.write('    "vector3 opticaxis" [ %.6f %.6f %.6f ]\n' % tuple(axis))
        f.write('Shape "trianglemesh" "point3 P" [\n')
        for p in corners:
            f.write("    %.6f %.6f %.6f\n" % tuple(p))
        f.write('  ] "integer indices" [\n')
        for t in tris:
            f.write("    %d %d %d\n" % t)
        f.write("  ]\n")
    print("axis %s, angle to vertical %.2f deg, height %.4f" % (axis, angle, height))


if __name__ == "__main__":
    main()
