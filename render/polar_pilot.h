/* polar_pilot: measures how much ignoring polarisation changes a scene's image, so that the
 * plan carries Stokes vectors where they show and not elsewhere (issue 28, docs/plan.md). A
 * scene that asks for nothing polarised (no sheet, analyser or Stokes output) but whose smooth
 * or rough glass and metal polarise what they reflect and transmit changes its intensities
 * wherever light meets a second Fresnel interface (a gem, glass in glass): the pilot renders a
 * small grid of tiles spread over the image a few samples per pixel with and without
 * polarisation and compares.
 *
 * The figure: per pixel the difference d = Y_polarised - Y_plain of mean luminance, from the
 * same samples (the scalar weights and every random choice are the same both ways, only the
 * carrier's factor differs), twice with disjoint sample ranges A and B; the mean of d_A d_B over
 * the pixels estimates the mean squared systematic change without its noise (A and B are
 * independent, so E[d_A d_B] = E[d]^2), and change = sqrt(max(0, mean d_A d_B)) / mean Y_plain,
 * the normalisation of the job's error estimate (film/error_estimate.h: RMS per-pixel error over
 * the mean luminance). A few samples leave that figure noisy (the jewel's reads 0.96 % at 4 spp,
 * 1.7-2.6 % at 16-64: docs/accuracy.md), so the decision takes its bound two standard errors
 * up -- the mean product plus twice its standard error over the pixels -- and carries
 * polarisation unless the pilot shows the change below POLAR_PILOT_TARGET: a wrong "on" costs
 * 10-50 % more time, a wrong "off" an image off by more than the target.
 *
 * The threshold is fixed rather than the job's --target-error: the stopping rules are the
 * master's and the scene must not depend on them (settings/settings.h), or a worker that loads
 * the scene itself and a client that shares its own would render one job two ways.
 *
 * Guarantees: the same figure for the same build on the same CPU (fixed tiles and sample
 * indices, one thread, no clock in it), but not across builds or CPUs; so it advises and never
 * decides (polar_pilot_apply). */
#ifndef PRISMFARM_POLAR_PILOT_H
#define PRISMFARM_POLAR_PILOT_H

#include "err.h"
#include "scene.h"

/* The change above which polarisation is carried: 1 % of the mean luminance, the error a
 * finished render is commonly taken to (docs/plan.md, "Polarisation"). */
#define POLAR_PILOT_TARGET 0.01
/* Samples per pixel of each of the four pilot renders, and the grid of tiles (of
 * POLAR_PILOT_TILE square pixels) spread over the image. */
#define POLAR_PILOT_SPP 4
#define POLAR_PILOT_GRID 8
#define POLAR_PILOT_TILE 4

/* Whether the pilot has anything to measure: polarisation is off, and the scene has a
 * conductor or dielectric (smooth or rough, not a crystal) that polarises. */
int polar_pilot_needed(const scene_t *scene);

/* What one measurement found: the change (as above), its pixels and samples per pixel, and the
 * wall time of the plain and the polarised renders (the same samples: their ratio is what
 * polarised transport costs; not read by any decision). */
typedef struct polar_pilot_result {
    double change;
    double change_hi; /* the change with the mean product 2 standard errors higher */
    int pixels, spp;
    double seconds_plain, seconds_polarised;
} polar_pilot_result_t;

/* Measures the change on a grid x grid of tiles (1..POLAR_PILOT_GRID, tile x tile pixels, the
 * whole image when smaller) at spp samples per pixel per run, whatever the scene's
 * polarisation setting (restored after). bench/polar_pilot.c takes it further than the pilot's
 * defaults for docs/accuracy.md. -1 with err when a render failed. */
int polar_pilot_measure(scene_t *scene, int grid, int tile, int spp, polar_pilot_result_t *out,
                        err_t *err);

/* Runs the pilot when polar_pilot_needed and it has not run on this scene and records what it
 * measured in scene->settings.polar_pilot, for the plan to report (above POLAR_PILOT_TARGET it
 * advises Integrator "bool polarized" true). It does not switch polarisation on: the decision
 * rests on rendered floats, which another build or another CPU's Embree path can move across
 * the threshold (a sanitizer build did, on tests/data/render/tiny.pbrt), and a farm whose
 * workers decided apart would render one job two ways; the scene file's option is the same on
 * every host. Returns 0 (also when nothing was needed), -1 with err when a render failed. */
int polar_pilot_apply(scene_t *scene, err_t *err);

#endif
