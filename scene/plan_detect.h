/* plan_detect: what the plan finds in a finished scene before it decides: which spectra and
 * textures vary over the film's range, where the mirror and glass shapes stand, and for each
 * light whether it reaches a diffuse or glossy surface through them (an L S+ D path: a
 * caustic) by visibility rays from fixed random keys, within a ray budget. Internal to the
 * plan (plan.c, plan_report.c); deterministic, no threads. */
#ifndef PRISMFARM_PLAN_DETECT_H
#define PRISMFARM_PLAN_DETECT_H

#include "plan_types.h"
#include "scene.h"

#include <stdint.h>

/* Every random number of the plan is keyed by this seed (and a light, a placement, an
 * arrival), never by the job's seed: the same scene gets the same plan whatever it renders
 * with. "plan" in ASCII. */
#define PLAN_SEED 0x706c616eull

/* Visibility sampling. A light sends PLAN_TARGET_RAYS rays at uniform points of each mirror
 * or glass placement (a collimated light PLAN_BEAM_RAYS rays along its normal); every specular
 * surface a ray reaches becomes an "arrival", from which PLAN_DIRECTIONS uniform directions
 * look for a diffuse surface (in the hemisphere the light was reflected into for a mirror, the
 * whole sphere for glass). At most PLAN_ARRIVALS_PER_SHAPE arrivals per shape are followed per
 * light and placement, so a diffuse surface covering more than about 4 pi / (16 * 64) sr
 * around the glass is found (docs/plan.md). */
#define PLAN_TARGET_RAYS 64
#define PLAN_BEAM_RAYS 256
#define PLAN_LIGHT_POINTS 64
#define PLAN_DIRECTIONS 64
#define PLAN_ARRIVALS_PER_SHAPE 16
#define PLAN_QUEUE_MAX 1024
#define PLAN_MAX_HOPS 8
#define PLAN_PASSTHROUGH_MAX 64
#define PLAN_PLACEMENTS_MAX 4096
/* Rays for the whole plan (a few tenths of a second at worst); a light still undecided when
 * they run out is assumed to need photons (missing light is worse than wasted time). */
#define PLAN_RAY_BUDGET (1u << 21)

/* "Varies over the film's range": sampled at this many wavelengths, by more than this
 * fraction of the largest value (the same 1e-6 as IOR_DISPERSIVE_EPSILON). */
#define PLAN_SPECTRAL_SAMPLES 35
#define PLAN_SPECTRAL_EPSILON 1e-6

/* A mirror or glass shape where it stands: a world shape (instance -1) or an object's shape
 * placed by an instance. */
typedef struct placement {
    int shape;
    int instance;
    vec3_t centre;
    const double *cdf; /* meshes: cumulative triangle areas (owned by the placements' list) */
} placement_t;

/* Light reaching a mirror or glass surface: where, from which direction, which shape, after
 * how many specular events, and the material of the path's first specular surface. */
typedef struct arrival {
    vec3_t p, ng, din;
    int shape;
    int hops;
    int root_material;
} arrival_t;

typedef struct tracer {
    const scene_t *s;
    int max_hops;
    uint64_t rays;
    uint64_t budget;
    /* Arrivals followed per shape in the current search (reset by bumping gen). */
    unsigned *stamp;
    int *visits;
    unsigned gen;
    arrival_t *queue;
} tracer_t;

typedef struct found {
    int glass_material;
    int receiver_material;
} found_t;

/* Whether sp varies over the grid's range (PLAN_SPECTRAL_SAMPLES wavelengths, by more
 * than PLAN_SPECTRAL_EPSILON of its largest value). */
int plan_detect_spectrum_varies(const spectrum_t *sp, spectral_grid_t g);

/* A texture varies with wavelength somewhere: checked at a 3 x 3 grid of texture
 * coordinates (a checkerboard's squares, an image's texels). */
int plan_detect_texture_varies(const texture_t *t, spectral_grid_t g);

/* Every mirror and glass shape where it stands, in shape order (at most PLAN_PLACEMENTS_MAX),
 * and the box around all of them; cdfs[shape] receives each specular mesh's cumulative
 * triangle areas. Returns the count, or -1 on out of memory. */
long plan_detect_placements(const scene_t *s, placement_t **out, double **cdfs, vec3_t *lo,
                            vec3_t *hi);

/* Decides whether light li needs photons. */
void plan_detect_light(tracer_t *t, plan_light_t *pl, const placement_t *pls, size_t npl,
                       double total_power, spectral_grid_t g);

#endif
