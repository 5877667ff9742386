/* subsurface: where light that entered a subsurface material (scene/material_subsurface.h, pbrt-v4's
 * SubsurfaceMaterial) leaves again, as pbrt-v4's VolPathIntegrator finds it: a probe segment
 * sampled from the BSSRDF's profile of one lane (bsdf/bssrdf.h) is traced through the scene;
 * of the surfaces of the same material it crosses, one is chosen uniformly (pbrt-v4's
 * reservoir of weight 1 each), and each lane is weighted by its profile S_p at that point over
 * the point's density. The caller then shades the exit with the exit lobe (bsdf.h
 * BSDF_SSS_EXIT, subsurface_exit_bsdf): next-event estimation and a cosine-sampled
 * continuation, as at any surface.
 *
 * Spectral lanes: each lane has its own medium (its wavelength's coefficients) and profile;
 * the probe follows the lane `hero`, and with spectral MIS (sel: each lane's probability of
 * being that lane) a lane's weight is S_p / (sum_k sel_k pdf_k) (one-sample MIS, balance
 * heuristic: the path integrator's rule for BSDF samples), else S_p / pdf_hero (pbrt-v4's r_p
 * does the same through its spectral MIS). The weights are finite and >= 0. */
#ifndef PRISMFARM_SUBSURFACE_H
#define PRISMFARM_SUBSURFACE_H

#include "material_subsurface.h"
#include "bsdf.h"
#include "rng.h"
#include "scene.h"

typedef struct subsurface_exit {
    surface_t sf;                  /* the exit point's surface */
    double weight[BSDF_MAX_LANES]; /* per lane: S_p / (choice probability x density) */
    int rays;                      /* probe rays traced, for the statistics */
} subsurface_exit_t;

/* The exit for light that entered material m (material_subsurface_table(m) set) at sf, for n lanes of
 * wavelengths lambda: u[0..2] place the probe (axis, radius, azimuth); rng chooses among its
 * hits. False when there is none (the probe found no surface of m, or the lane's medium has
 * no profile): the path ends, as in pbrt-v4. */
bool subsurface_find_exit(const scene_t *scene, const material_t *m, const surface_t *sf,
                          const double *lambda, int n, int hero, const double *sel,
                          const double u[3], rng_stream_t *rng, subsurface_exit_t *out);

/* The exit lobe of m for n lanes in radiance or importance mode. */
void subsurface_exit_bsdf(const material_t *m, int n, bsdf_mode_t mode, bsdf_t *b);

#endif
