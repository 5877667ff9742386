#!/usr/bin/env python3
"""Writes scenes/michel_levy.pbrt: the Michel-Levy interference-colour chart rendered as a
polariscope sees it (docs/physics.md 14.1). A D65 light box, a polariser at 0 degrees over it,
three rows of thin birefringent strips with their optic axes at 45 degrees, and the camera's
analyser at 90 degrees (crossed): every strip shows the colour (1/2) D65 sin^2(pi Gamma / lambda)
of its retardation Gamma, and the gaps between strips and rows are black.

Rows, top to bottom, each 81 strips from Gamma = 0 to 2000 nm at 550 nm in steps of 25 nm:
  1. the chart itself: "float retardation" Gamma, the same at every wavelength (no dispersion
     of the birefringence, as the chart assumes);
  2. a quartz wedge: "string crystal" "quartz", thickness Gamma / (n_e - n_o)(550 nm), 0 to
     about 219 um, with quartz's own dispersion of n_e - n_o (Ghosh 1999);
  3. a calcite wedge: thickness 0 to about 11.6 um (n_o - n_e = 0.172 at 550 nm), whose
     birefringence falls by 12 % from 400 to 700 nm, so its higher orders drift from the chart.
Only the standard library; the indices at 550 nm are computed here from the same Sellmeier
coefficients as optics/crystal.c (refractiveindex.info, Ghosh 1999). Run from the repository
root: python3 tools/gen_michel_levy.py
"""
import math
import os

ROOT = os.path.join(os.path.dirname(__file__), "..")


def ghosh(lam_um, a, b, c, d, e):
    """Ghosh 1999's form n^2 = A + B l^2/(l^2 - C) + D l^2/(l^2 - E)."""
    l2 = lam_um * lam_um
    return math.sqrt(a + b * l2 / (l2 - c) + d * l2 / (l2 - e))


# refractiveindex.info main/SiO2/Ghosh-o, -e and main/CaCO3/Ghosh-o, -e
QUARTZ_O = (1.28604141, 1.07044083, 1.00585997e-2, 1.10202242, 100)
QUARTZ_E = (1.28851804, 1.09509924, 1.02101864e-2, 1.15662475, 100)
CALCITE_O = (1.73358749, 0.96464345, 1.94325203e-2, 1.82831454, 120)
CALCITE_E = (1.35859695, 0.82427830, 1.06689543e-2, 0.14429128, 120)

STRIPS = 81
STEP_NM = 25.0
WIDTH = 8.1  # scene units across a row
HEIGHT = 0.9
ROWS_Y = (1.15, 0.0, -1.15)
QUAD = ('Shape "trianglemesh" "point3 P" [ -{w} -{h} 0  {w} -{h} 0  {w} {h} 0  -{w} {h} 0 ] '
        '"integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]')


def main():
    dn_q = ghosh(0.55, *QUARTZ_E) - ghosh(0.55, *QUARTZ_O)
    dn_c = ghosh(0.55, *CALCITE_O) - ghosh(0.55, *CALCITE_E)
    pitch = WIDTH / STRIPS
    strip = QUAD.format(w=f"{0.46 * pitch:.4f}", h=f"{HEIGHT / 2:.4f}")
    big = QUAD.format(w="9", h="6")
    out = []
    out.append(f"""# The Michel-Levy interference-colour chart in a polariscope (docs/physics.md 14.1): a D65
# light box under a polariser at 0 degrees, three rows of thin birefringent strips with their
# optic axes at 45 degrees, and the camera's analyser crossed at 90 degrees. Each strip shows
# (1/2) D65 sin^2(pi Gamma / lambda), Gamma its retardation, from 0 (black) at the left to
# 2000 nm at the right in steps of 25 nm: first-order grey, white and yellow, the first-order
# red near 550 nm, then the blue, green, yellow and red of the second and third orders, paling
# toward the white of higher orders. Top: the chart (Gamma the same at every wavelength, "float
# retardation"). Middle: a quartz wedge, 0 to {2000 / dn_q / 1000:.0f} um (n_e - n_o = {dn_q:.5f} at 550 nm),
# close to the chart. Bottom: a calcite wedge, 0 to {2000 / dn_c / 1000:.1f} um (n_o - n_e = {dn_c:.4f}),
# whose birefringence falls 12 % across the visible, so its higher orders drift from the chart.
# The thin-plate model holds: the walk-off of the thickest calcite strip, about 1.2 um, is far
# below a pixel. "retarder" with "retardation", "crystal" and "thickness" is a prismfarm
# extension (docs/scene-format.md); pbrt-v4 refuses it. Written by tools/gen_michel_levy.py.
# Test size: prismfarm render scenes/michel_levy.pbrt --res 200x100 --spp 4
LookAt 0 0 10   0 0 0   0 1 0
# The analyser in front of the lens, crossed with the polariser (a sheet there would work as
# well but cost a bounce, after which Russian roulette starts).
Camera "orthographic" "float screenwindow" [ -4.2 4.2 -2.1 2.1 ] "float analyzer" [ 90 ]
# 32 lanes a sample, one per bucket ("fanout"): the colours, which vary quickly with
# wavelength at high orders, are estimated from wavelengths stratified over 360-830 nm.
Film "spectral" "integer xresolution" [ 800 ] "integer yresolution" [ 400 ]
    "integer nbuckets" [ 32 ] "float lambdamin" [ 360 ] "float lambdamax" [ 830 ]
    "string filename" "michel_levy.exr"
Sampler "zsobol" "integer pixelsamples" [ 16 ]
Integrator "path" "integer maxdepth" [ 8 ] "string dispersion" "fanout"
WorldBegin

# The light box.
AttributeBegin
  AreaLightSource "diffuse" "spectrum L" "stdillum-D65"
  Material "diffuse" "rgb reflectance" [ 0 0 0 ]
  Translate 0 0 -3
  {big}
AttributeEnd

# The polariser over the box, horizontal (its u direction, world x). The analyser, crossed with
# it, is the camera's (vertical in the image), as in a microscope's eyepiece. (pbrt's LookAt is
# left-handed: world +x is the image's left, so each row runs from +x to -x.)
AttributeBegin
  Material "polarizer" "float angle" [ 0 ]
  Translate 0 0 -2
  {big}
AttributeEnd
""")
    rows = (("the chart: retardation Gamma", lambda g: f'"float retardation" [ {g:g} ]'),
            ("quartz", lambda g: f'"string crystal" "quartz" "float thickness" [ {g / dn_q / 1000:.4f} ]'),
            ("calcite", lambda g: f'"string crystal" "calcite" "float thickness" [ {g / dn_c / 1000:.5f} ]'))
    for (name, params), y in zip(rows, ROWS_Y):
        out.append(f"\n# {name}, 0 to 2000 nm at 550 nm.\n")
        for i in range(STRIPS):
            g = i * STEP_NM
            x = WIDTH / 2 - (i + 0.5) * pitch
            out.append(f'AttributeBegin\n  Material "retarder" "float angle" [ 45 ] {params(g)}\n'
                       f"  Translate {x:.4f} {y} 0\n  {strip}\nAttributeEnd\n")
    with open(os.path.join(ROOT, "scenes", "michel_levy.pbrt"), "w") as f:
        f.write("".join(out))


if __name__ == "__main__":
    main()
