#!/usr/bin/env python3
"""Writes scenes/jewel_polariser/frame0001.pbrt ... frame0012.pbrt: scenes/jewel.pbrt
photographed through a polarising filter turned 15 degrees from one frame to the next
(0, 15, ..., 165: half a turn, after which a linear polariser repeats). Each frame is
jewel.pbrt with the camera's analyser ("float analyzer", docs/physics.md 14) at that angle,
its Include paths made relative to the frames' folder and its output named after the frame.
Light that left the diamond after reflections at its facets, and the gold's reflections, are
partly polarised, each facet's flash its own way, so the flashes brighten and fade at different
angles as the filter turns, while the wall and the table (diffuse: they depolarise, the
caustic's specks on them too) stay at half.

Rerun after editing scenes/jewel.pbrt (the frames are copies). Only the standard library.
Run from the repository root: python3 tools/gen_jewel_polariser.py
Render the sequence (docs/farm.md, "Frame sequences"):
  prismfarm render 'scenes/jewel_polariser/frame%04d.pbrt' --frames 1-12 \\
      -o 'jewel_polariser%04d.exr' --res 160x120 --spp 16
"""
import os
import re

ROOT = os.path.join(os.path.dirname(__file__), "..")
FRAMES = 12
STEP = 15.0


def main():
    with open(os.path.join(ROOT, "scenes", "jewel.pbrt")) as f:
        src = f.read()
    if not re.search(r'^Camera "perspective"', src, re.M):
        raise SystemExit("scenes/jewel.pbrt: no Camera line to put the analyser on")
    out_dir = os.path.join(ROOT, "scenes", "jewel_polariser")
    os.makedirs(out_dir, exist_ok=True)
    for k in range(1, FRAMES + 1):
        angle = (k - 1) * STEP
        text = re.sub(r'^(Camera "perspective".*)$', rf'\1 "float analyzer" [ {angle:g} ]', src,
                      count=1, flags=re.M)
        text = re.sub(r'Include "(?!/)', 'Include "../', text)
        text = re.sub(r'"string filename" "jewel\.exr"',
                      f'"string filename" "jewel_polariser{k:04d}.exr"', text)
        head = (f"# Frame {k} of {FRAMES}: scenes/jewel.pbrt through a polarising filter at "
                f"{angle:g} degrees from the\n# image's right toward its up. Written by "
                "tools/gen_jewel_polariser.py from jewel.pbrt: edit that and rerun.\n")
        with open(os.path.join(out_dir, f"frame{k:04d}.pbrt"), "w") as f:
            f.write(head + text)


if __name__ == "__main__":
    main()
