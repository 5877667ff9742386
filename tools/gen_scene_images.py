#!/usr/bin/env python3
"""Generates the images of scenes/lamps.pbrt's lights as 8-bit sRGB PNGs in scenes/images/.

- test_card.png (64 x 40): the projection light's slide, colour bars over a grey ramp with a
  white frame and a black arrow in the top-left corner pointing up (so that a render shows
  whether the slide lands upright and unmirrored);
- gonio_bands.png (256 x 256): the goniometric lamp's intensity, an equal-area octahedral map
  (pbrt-v4's layout, Clarberg 2008) that is dark upward and throws bands of light downward,
  brightest 40-60 degrees from straight down; grey, since pbrt-v4 keeps only the channel mean
  (the lamp's colour is its "I");
- window.png (32 x 48): the image area light's "stained-glass window", coloured panes between
  dark leads.
Only the standard library: PNG chunks written with zlib. Run from the repository root:
python3 tools/gen_scene_images.py
"""
import math
import os
import struct
import zlib

OUT = os.path.join(os.path.dirname(__file__), "..", "scenes", "images")


def write_png(name, w, h, pixel):
    """pixel(x, y) -> (r, g, b) linear in [0, 1], y = 0 the top row; stored sRGB-encoded."""

    def encode(v):
        v = min(1.0, max(0.0, v))
        s = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
        return int(round(255 * s))

    raw = bytearray()
    for y in range(h):
        raw.append(0)
        for x in range(w):
            raw.extend(encode(c) for c in pixel(x, y))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(bytes(raw), 9)) + chunk(b"IEND", b"")
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(png)


def test_card(x, y):
    w, h = 64, 40
    if x < 2 or y < 2 or x >= w - 2 or y >= h - 2:
        return (1.0, 1.0, 1.0)
    # an arrow pointing up in the top-left corner: a stem and a head
    ax, ay = x - 3, y - 3
    if (0 <= ay < 18 and 2 <= ax <= 3) or (0 <= ay < 5 and abs(ax - 2.5) <= ay + 0.5):
        return (0.0, 0.0, 0.0)
    bars = [(0.75, 0.75, 0.75), (0.75, 0.75, 0.0), (0.0, 0.75, 0.75), (0.0, 0.75, 0.0),
            (0.75, 0.0, 0.75), (0.75, 0.0, 0.0), (0.0, 0.0, 0.75)]
    if y < 28:
        return bars[min(6, (x - 2) * 7 // (w - 4))]
    g = (x - 2) / (w - 5)
    return (g, g, g)


def sq_to_sphere(u, v):
    """pbrt-v4 EqualAreaSquareToSphere for (u, v) in [0, 1]^2."""
    u, v = 2 * u - 1, 2 * v - 1
    up, vp = abs(u), abs(v)
    sd = 1 - (up + vp)
    r = 1 - abs(sd)
    phi = (0 if r == 0 else (vp - up) / r + 1) * math.pi / 4
    z = math.copysign(1 - r * r, sd)
    s = r * math.sqrt(max(0.0, 2 - r * r))
    return (math.copysign(abs(math.cos(phi)), u) * s, math.copysign(abs(math.sin(phi)), v) * s, z)


def gonio_bands(x, y):
    n = 256
    d = sq_to_sphere((x + 0.5) / n, (y + 0.5) / n)
    down = math.degrees(math.acos(max(-1.0, min(1.0, -d[2]))))  # angle from light-space -z
    if down > 80:
        return (0.0, 0.0, 0.0)
    level = 0.25 + 0.75 * math.exp(-((down - 50) / 12) ** 2)
    if int(down / 8) % 2:
        level *= 0.35
    return (level, level, level)


def window(x, y):
    if x % 8 == 0 or y % 8 == 0:
        return (0.02, 0.02, 0.02)
    panes = [(1.0, 0.15, 0.1), (0.1, 0.3, 1.0), (1.0, 0.8, 0.1), (0.1, 0.8, 0.2), (0.7, 0.2, 0.9)]
    return panes[(x // 8 + 2 * (y // 8)) % 5]


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    write_png("test_card.png", 64, 40, test_card)
    write_png("gonio_bands.png", 256, 256, gonio_bands)
    write_png("window.png", 32, 48, window)
