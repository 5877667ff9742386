#include "render.h"

#include "camera.h"
#include "colour.h"
#include "crystal_scatter.h"
#include "delta.h"
#include "equiangular.h"
#include "fanout.h"
#include "lights.h"
#include "phase_hg.h"
#include "photon_volume.h"
#include "regularize.h"
#include "polar_frame.h"
#include "rng.h"
#include "sample.h"
#include "sampler.h"
#include "shading.h"
#include "sheet.h"
#include "spectral_grid.h"
#include "specular.h"
#include "subsurface.h"
#include "volume.h"
#include "wavelength.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define LANES RENDER_MAX_BUCKETS
_Static_assert(LANES <= BSDF_MAX_LANES, "a bsdf_t holds every lane of a path");
#define STACK_MAX 192
/* Russian roulette starts after this many bounces (thesis eq. 2.32-2.33; docs/physics.md
 * §2.5). */
#define RR_DEPTH 3
#define RR_MIN 0.05
/* Pass-through surfaces ("interface") do not count as bounces; this bounds them anyway. */
#define MAX_PASSTHROUGH 64
/* Whitted follows both branches of a glass event; with two glass objects facing each other
 * that is a binary tree of depth maxdepth (ball above slab: x1.25 work per level, hours at
 * 64). Past 2 maxdepth branches per lane of a camera sample (a chain, such as a slab's
 * internal reflections, needs one per bounce and lane) it chooses one branch at random,
 * weighted by 1/probability (unbiased), so the work stays linear in maxdepth. */
#define WHITTED_BRANCHES_PER_BOUNCE 2

/* A path and the spectral lanes it carries. All lanes share the path's direction. A lane is a
 * wavelength used for the physics and a throughput; `bucket` says where its light goes:
 * a fixed framebuffer bucket (fan-out) or, when -1, the bucket containing lambda, weighted by
 * 1/pdf (hero wavelengths, continuous). */
typedef struct path {
    vec3_t org, dir;
    int n;
    int depth;
    int passthrough;
    int specular;     /* the last bounce was specular (or this is the camera ray) */
    double bsdf_pdf;  /* solid-angle pdf of the last diffuse bounce, for MIS */
    vec3_t prev_p;    /* where the last bounce happened */
    vec3_t prev_n;    /* the normal next-event estimation used there (0 in a medium) */
    int mono;         /* every lane refracts alike: one physical wavelength */
    int dispersed;    /* the path has had its first dispersive refraction */
    int splits;       /* dense-stone events it followed both ways (split_here) */
    int sheets;       /* polariser and retarder sheets crossed: not bounces for the roulette */
    /* What Russian roulette multiplies the throughput by before it compares it with 1: 1,
     * except after events at a dense stone with splitting on, whose factors that are not losses
     * it undoes (split_dense). */
    double rr_scale;
    /* The photon integrator's split: non-specular bounces so far (surfaces and medium
     * scatterings), the surfaces' among them (a glossy receiver gathers at the first; medium
     * scatterings before it take the volume store and leave the surface rule alone), and
     * specular ones since the last (or since the camera). */
    int diffuse_bounces;
    int surface_bounces;
    int specular_since_diffuse;
    /* The medium the path travels in (an index into scene->media, -1: vacuum); read only when
     * the scene's media are simulated (render_settings_t.media). */
    int medium;
    /* Surface hits and medium events so far: which block of the sampler's dimensions the path's
     * next vertex draws from (DIM_VERTEX). */
    int vertex;
    /* Inside a uniaxial crystal, the wave the path travels as (bsdf/uniaxial.h: 0 o, 1 e). */
    int wave;
    /* Polarised transport (render_settings_t.polarised): the lanes' Stokes carriers polar_t
     * are live, measured in the frame polar_x (polar/polar_frame.h). The scalar weights beta
     * stay what they are without polarisation; polar_t holds only the polarising part of each
     * element (mueller_normalised), so that the camera records beta T S for light S. */
    int polar;
    vec3_t polar_x;
    /* The lanes come last so that a new path clears only the fields above. */
    double lambda[LANES];
    double beta[LANES];
    double pdf[LANES];
    int bucket[LANES];
    mueller_t polar_t[LANES]; /* read only when polar */
} path_t;

/* Lights whose spectral values render keeps per lane (the first LE_CACHE_LIGHTS of the scene;
 * the rest are evaluated every time), and the slot of the environment's sum. */
#define LE_CACHE_LIGHTS 8
#define LE_CACHE_ENV LE_CACHE_LIGHTS

/* A light's spectral value at one lane's wavelength, remembered with that wavelength: a path's
 * lanes keep their wavelengths from bounce to bounce, and every light sample and emission hit
 * would evaluate the spectrum again (a blackbody's expm1 per lane). Keyed by the wavelength
 * itself, so a lane whose wavelength changed misses and the value is always exactly what the
 * evaluation gives. */
typedef struct le_entry {
    double lambda; /* NaN: empty */
    double value;
} le_entry_t;

typedef struct ctx {
    const scene_t *scene;
    const sensor_t *sensor; /* the film's sensor; NULL: cie1931, XYZ as is */
    const render_settings_t *rs;
    const spectral_table_t *table; /* rs->grid's boundaries, for the splats */
    double *contrib;
    /* The sample's CIE XYZ, each lane's light at its own wavelength (splat), and what fan-out
     * lanes need for it: the grid's range and bucket width. */
    double xyz[3];
    double fan_min, fan_max, fan_width;
    /* The camera sample's low-discrepancy numbers, and the first dimension of the current
     * vertex's block (the layout below). */
    sampler_t smp;
    uint32_t dim_base;
    sampler_cache_t smp_cache; /* what the pixel's samples share */
    double wavelength_u;       /* the hero tuple's number (DIM_WAVELENGTH), for direct_lanes */
    /* Philox numbers for the random walks whose length has no bound: a layered BSDF's walk
     * between its interfaces, and delta and ratio tracking in media (bsdf/layered.h,
     * render/volume.h). They cannot have fixed dimensions, and a low-discrepancy dimension
     * reused at varying depths of one walk would correlate its steps; keyed apart from the
     * sampler (WALK_SEED_MIX), so that the "independent" sampler's numbers are not these. */
    rng_stream_t rng;
    render_stats_t *stats;
    path_t *stack;
    int top;
    int branches;     /* Whitted branches pushed for the current camera sample */
    int max_branches; /* WHITTED_BRANCHES_PER_BOUNCE x maxdepth x lanes */
    /* The photon integrator's caustic store, or NULL. */
    const photon_store_t *photons;
    int glossy_photons; /* the store holds photons on glossy receivers too (it keeps directions) */
    int mindepth;       /* the store holds L S^k D (and L S^k G) paths with k >= mindepth */
    double *irradiance; /* grid.n buckets, for one estimate */
    le_entry_t le_cache[LE_CACHE_LIGHTS + 1][LANES];
    int media; /* the scene's media are simulated (render/volume.h) */
    /* Equiangular sampling is on (render_settings_t.medium_sampling) and the scene has a light
     * it samples toward (eq_light_ok). */
    int eq_lights;
    /* The current camera path's traversal of a coherent crystal (render/crystal_coherent.h):
     * read only while its wave is UNIAXIAL_COHERENT; nothing splits a path inside one. */
    crystal_coherent_t coh;
    /* The pdf of a BSDF-sampled direction weighs the emission that direction finds: with the
     * path integrator's MIS and a light that a ray can hit (an area or infinite light). Else
     * the coated models skip their stochastic pdf estimate (a random walk of its own). */
    int bsdf_mis;
    /* Polarised transport: the tile's Stokes planes S1-S3 follow the S0 buckets (stokes), and
     * +1 or -1 as the camera's k x right is its image up or down (splat_stokes). */
    int stokes;
    double frame_sign;
    /* Lamp probes (probe_lamps): the sphere lights whose directly seen emission each camera
     * sample estimates from LAMP_PROBES positions, when on for this render (probing). */
    lights_probes_t probes;
    int probing;
    int probe_pixel; /* probing, and the current pixel's rays may meet a probe lamp */
} ctx_t;

/* The dimension layout of a camera sample (docs/rendering.md, "Sampler"): dimension d means
 * the same decision in every sample of a pixel, so the sampler's stratification over the
 * pixel's samples (a (0,2)-net for each 2D draw of the Sobol samplers) applies to that
 * decision. First the camera's block, then one block per vertex of the path (a surface hit or
 * a medium event, counted with pass-through surfaces, so that no number is drawn twice for one
 * path: two decisions on one number would correlate them). Branches pushed at a vertex (Whitted,
 * the fan-out's rays) continue with the same later blocks as the path they split from: each
 * branch is an unbiased estimate on its own. */
enum {
    DIM_FILM = 0,       /* 2D: the position in the pixel (through the filter) */
    DIM_WAVELENGTH = 2, /* 1D: the hero wavelength, or the fan-out lanes' common jitter */
    DIM_LENS = 3,       /* 2D: the point on the lens */
    DIM_LENS_LANE = 5,  /* 1D: the lane a dispersive realistic lens follows (fan-out) */
    DIM_CAMERA = 6,     /* the camera block's size */
};
enum {
    VD_MIX = 0,         /* 1D: a mix material's choice */
    VD_LIGHT = 1,       /* 1D: which light (lights_sample's u[0]) */
    VD_LIGHT_PART = 2,  /* 1D: which triangle of a mesh light (u[1]) */
    VD_LIGHT_POINT = 3, /* 2D: the point on the light or its direction (u[2], u[3]) */
    VD_LANE = 5,        /* 1D: the lane whose lobe samples (spectral MIS) */
    VD_LOBE = 6,        /* 1D: the BSDF's lobe */
    VD_DIRECTION = 7,   /* 2D: the BSDF's, cosine or phase function's direction */
    VD_REFLECT = 9,     /* 1D: reflect or refract at smooth glass */
    VD_FAN_JITTER = 10, /* 1D: the fan-out's split shift */
    VD_FAN_PICK = 11,   /* 1D: the fan-out ray followed at a later dispersive event */
    VD_ROULETTE = 12,   /* 1D: Russian roulette */
    VD_GATHER = 13,     /* 1D: the glossy gather's systematic pick */
    DIM_VERTEX = 14,    /* a vertex block's size */
};

/* Vertex slot `slot` of the current vertex, one or two dimensions. */
static double draw1(ctx_t *c, int slot)
{
    return sampler_1d(&c->smp, c->dim_base + (uint32_t)slot);
}
static void draw2(ctx_t *c, int slot, double u[2])
{
    sampler_2d(&c->smp, c->dim_base + (uint32_t)slot, u);
}

/* Puts the walk stream at a position fixed by the vertex's block and a slot of it, before a
 * layered BSDF's walk: the walk keys its first events' stratified numbers by that position
 * (bsdf/layered.c, walk_begin), so one decision draws from one sequence over the pixel's
 * samples. Positions are 2^16 numbers apart, more than any walk draws. */
static void walk_position(ctx_t *c, int slot)
{
    c->rng.next_dim = (c->dim_base + (uint32_t)slot) << 16;
    c->rng.has_spare = 0;
}

/* The path's next vertex takes the next block of dimensions. */
static void vertex_begin(ctx_t *c, path_t *p)
{
    c->dim_base = DIM_CAMERA + DIM_VERTEX * (uint32_t)p->vertex++;
}

/* lights_sample's four uniforms for next-event estimation at the current vertex: the one
 * place that lays them out (light choice, mesh part, then the 2D point). */
static void light_uniforms(ctx_t *c, double u[4])
{
    u[0] = draw1(c, VD_LIGHT);
    u[1] = draw1(c, VD_LIGHT_PART);
    draw2(c, VD_LIGHT_POINT, u + 2);
}

/* lights_value(light li, lambda) for lane j, through the cache. */
static double light_value_lane(ctx_t *c, int li, int j, double lambda)
{
    const light_t *l = &c->scene->lights[li];
    if (li >= LE_CACHE_LIGHTS)
        return lights_value(l, lambda);
    le_entry_t *e = &c->le_cache[li][j];
    if (e->lambda != lambda) {
        e->value = lights_value(l, lambda);
        e->lambda = lambda;
    }
    return e->value;
}

/* lights_environment(lambda) for lane j, through the cache (the uniform environments). */
static double environment_lane(ctx_t *c, int j, double lambda)
{
    le_entry_t *e = &c->le_cache[LE_CACHE_ENV][j];
    if (e->lambda != lambda) {
        e->value = lights_environment(c->scene, lambda);
        e->lambda = lambda;
    }
    return e->value;
}

/* Copies a path: its fields and its n live lanes (lanes past n are never read), not the
 * LANES-long arrays whole (a path_t is about 2 kB; hero paths use 4 lanes). */
static void path_copy(path_t *dst, const path_t *src)
{
    memcpy(dst, src, offsetof(path_t, lambda));
    size_t n = (size_t)src->n;
    memcpy(dst->lambda, src->lambda, n * sizeof src->lambda[0]);
    memcpy(dst->beta, src->beta, n * sizeof src->beta[0]);
    memcpy(dst->pdf, src->pdf, n * sizeof src->pdf[0]);
    memcpy(dst->bucket, src->bucket, n * sizeof src->bucket[0]);
    if (src->polar)
        memcpy(dst->polar_t, src->polar_t, n * sizeof src->polar_t[0]);
}

static double power_heuristic(double a, double b)
{
    double a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0 ? a2 / (a2 + b2) : 0.0;
}

/* 1 / the density of a fan-out lane's wavelength, for its exact XYZ (docs/rendering.md,
 * "Colour"). Lane i starts at lambda_i = c_i + u w, c_i its bucket's centre, w the width and
 * u uniform in [-1/2, 1/2] shared by the lanes (render_tile): lambda_i is uniform over bucket
 * i, density 1/w. The first dispersive refraction moves every lane by S w more (fanout_split's
 * shift S, uniform in [-1/2, 1/2], applied to the lanes' wavelengths, which are evenly spaced
 * by w): lambda' = c_i + (u + S) w with u + S triangular on [-1, 1], so the lanes' wavelengths
 * together have the density sum_i tri((lambda - c_i) / w) / w, which is 1/w between the first
 * and the last centre (the tents add up to one) and falls linearly to 1/(2w) at the grid's
 * ends. Lanes outside the grid's range weigh 0, so that the estimate is of the colour of the
 * grid's range, as for undispersed lanes. */
static double fanout_inverse_density(const ctx_t *c, const path_t *p, double lambda)
{
    const double w = c->fan_width;
    if (!p->dispersed || c->rs->grid.n == 1)
        return w;
    if (!(lambda >= c->fan_min && lambda <= c->fan_max))
        return 0.0;
    /* Distance past the first (last) centre, in widths: at most 1/2 inside the grid. */
    double d = fmax(c->fan_min + 0.5 * w - lambda, lambda - (c->fan_max - 0.5 * w)) / w;
    return d > 0.0 ? w / (1.0 - d) : w;
}

/* The Stokes output's S1-S3 planes (render_settings_t.stokes: the tile's buckets are the S0
 * planes then S1, S2, S3, each grid.n long): lane j's light v beta times T's first column,
 * splatted into each plane as the S0 bucket is; no XYZ. The carried frame's y is k x right,
 * which for a camera that shows its up as image up reversed (c->frame_sign -1: pbrt's LookAt)
 * is image down, so S2 takes that sign and the planes are in the image's (right, up) frame. */
static void splat_stokes(ctx_t *c, const path_t *p, int j, double v, const double *ls)
{
    const int nb = c->rs->grid.n;
    for (int k = 1; k < 4; k++) {
        const double *t = p->polar_t[j].m[k];
        double vk = v * (ls ? t[0] + t[1] * ls[1] + t[2] * ls[2] + t[3] * ls[3] : t[0]) *
                    (k == 2 ? c->frame_sign : 1.0);
        if (vk == 0.0)
            continue;
        double *plane = c->contrib + k * nb;
        if (p->bucket[j] >= 0)
            plane[p->bucket[j]] += vk;
        else if (spectral_table_splat(c->table, plane, p->lambda[j], vk / WAVELENGTH_HERO_COUNT,
                                      p->pdf[j], SPECTRAL_SPLAT_BOX))
            c->contrib[0] = NAN;
    }
}

/* Adds light value(lane) * beta(lane) to the sample's buckets, and its XYZ at the lane's own
 * wavelength to the sample's colour: v xbar(lambda) / (p(lambda) CIE_Y_INTEGRAL), p the density
 * the lane's wavelength was drawn with (the hero tuple's pdf over its lanes' count, or the
 * fan-out lane's), so that the colour is an unbiased estimate of the spectrum's XYZ (pbrt-v4's
 * RGBFilm::AddSample, SampledSpectrum::ToXYZ), whatever the buckets. */
static void splat_polarised(ctx_t *c, const path_t *p, int j, double value, const double *ls)
{
    double v = value * p->beta[j];
    if (p->polar) {
        /* The light's normalised Stokes vector ls in the path's frame (NULL: unpolarised,
         * (1, 0, 0, 0), so that the camera records T's first column). */
        if (c->stokes)
            splat_stokes(c, p, j, v, ls);
        const double *t = p->polar_t[j].m[0];
        v *= ls ? t[0] + t[1] * ls[1] + t[2] * ls[2] + t[3] * ls[3] : t[0];
    }
    if (v == 0.0)
        return;
    double inv_density;
    if (p->bucket[j] >= 0) {
        c->contrib[p->bucket[j]] += v;
        inv_density = fanout_inverse_density(c, p, p->lambda[j]);
    } else {
        if (spectral_table_splat(c->table, c->contrib, p->lambda[j], v / WAVELENGTH_HERO_COUNT,
                                 p->pdf[j], SPECTRAL_SPLAT_BOX)) {
            /* The splat refuses a NaN or an overflow (value / (pdf width) > DBL_MAX). Poison the
             * sample so that tilebuf_add_sample drops it whole and it is counted in
             * render_stats_t.nonfinite, rather than losing this contribution silently. */
            c->contrib[0] = NAN;
            return;
        }
        inv_density = 1.0 / (WAVELENGTH_HERO_COUNT * p->pdf[j]);
    }
    xyz_t m = c->sensor ? sensor_response(c->sensor, p->lambda[j]) : cie_cmf_eval(p->lambda[j]);
    double k = v * inv_density / CIE_Y_INTEGRAL;
    c->xyz[0] += k * m.x;
    c->xyz[1] += k * m.y;
    c->xyz[2] += k * m.z;
}

/* splat for unpolarised light. */
static void splat(ctx_t *c, const path_t *p, int j, double value)
{
    splat_polarised(c, p, j, value, NULL);
}

static double max_beta(const path_t *p)
{
    /* fmax(m, |beta|) written out (gcc calls libm for fmax): a NaN lane is skipped as fmax
     * skips it, and m, never NaN, keeps its sign of zero. */
    double m = 0.0;
    for (int j = 0; j < p->n; j++) {
        double a = fabs(p->beta[j]);
        if (a > m)
            m = a;
    }
    return m;
}

static int push(ctx_t *c, const path_t *p)
{
    if (c->top >= STACK_MAX)
        return -1;
    path_copy(&c->stack[c->top++], p);
    c->branches++;
    return 0;
}

/* Where next-event estimation samples a light from point x with unit shading normal n
 * ((0, 0, 0) in a medium): under "path" BSDF or phase sampling always follows it and competes
 * under MIS, so image lights sample their compensated distribution; Whitted's single light
 * sample has nothing beside it (docs/rendering.md, "Image lights"). */
static lights_at_t light_site(const ctx_t *c, vec3_t x, vec3_t n)
{
    return (lights_at_t){.p = x, .n = n, .mis = c->rs->integrator == INTEGRATOR_PATH};
}

/* The site of the next-event estimation at the vertex a BSDF- or phase-sampled path left, for
 * its MIS weight: only asked under "path" after a non-specular bounce, and every such vertex
 * estimated with mis set (light_site), so the light pdf is of the distribution (and the light
 * BVH's importance at the same point and normal) that sampled. */
static lights_at_t light_site_behind(const path_t *p)
{
    return (lights_at_t){.p = p->prev_p, .n = p->prev_n, .mis = 1};
}

/* Lanes for light the camera ray sees directly (a lamp, the environment): its colour noise is
 * that of the hero tuple's 4 wavelengths alone, which is most of the noise of a small bright
 * lamp's pixels (veach-mis's smallest sphere, docs/performance.md). Such light has no
 * throughput in front of it, so evaluating it at more wavelengths costs only the emission's
 * spectrum: DIRECT_LANES wavelengths rotated by 1/DIRECT_LANES of the hero's own distribution
 * (u_k = frac(u + k / DIRECT_LANES), the hero tuple's rotation made finer, and its 4
 * wavelengths among them). Each wavelength alone has the hero's density p, so with each lane's
 * pdf set to p DIRECT_LANES / WAVELENGTH_HERO_COUNT, splat's 1 / (WAVELENGTH_HERO_COUNT pdf)
 * becomes 1 / (DIRECT_LANES p): the estimate (1 / K) sum_k L(lambda_k) / p(lambda_k) stays
 * unbiased. Only for an untouched hero camera ray: no bounce, every lane's throughput 1 (no
 * lens or medium in front), no dispersion, no polarisation; else p itself. */
#define DIRECT_LANES 16
_Static_assert(DIRECT_LANES <= LANES && DIRECT_LANES % WAVELENGTH_HERO_COUNT == 0,
               "the direct lanes fit a path and contain the hero tuple's rotation");

static const path_t *direct_lanes(const ctx_t *c, const path_t *p, path_t *tmp)
{
    /* Not with polarised transport: the lanes' Stokes carriers (an analyser in front of the
     * camera) are the hero tuple's 4. */
    if (p->depth != 0 || p->n != WAVELENGTH_HERO_COUNT || p->dispersed || c->media || p->polar ||
        c->rs->dispersion != DISPERSION_HERO || c->rs->direct_hero_only)
        return p;
    for (int j = 0; j < p->n; j++)
        if (p->bucket[j] >= 0 || p->beta[j] != 1.0 || !(p->pdf[j] > 0.0))
            return p;
    memcpy(tmp, p, offsetof(path_t, lambda));
    tmp->n = DIRECT_LANES;
    const double scale = (double)DIRECT_LANES / WAVELENGTH_HERO_COUNT;
    for (int k = 0; k < DIRECT_LANES; k++) {
        double u = c->wavelength_u + (double)k / DIRECT_LANES;
        u -= floor(u);
        wavelength_sample_t w =
            c->rs->visible_sampling
                ? wavelength_sample_visible(u)
                : wavelength_sample_uniform(u, c->rs->grid.lambda_min, c->rs->grid.lambda_max);
        tmp->lambda[k] = w.lambda;
        tmp->pdf[k] = w.pdf * scale;
        tmp->beta[k] = w.pdf > 0.0 ? 1.0 : 0.0;
        tmp->bucket[k] = -1;
    }
    return tmp;
}

/* Emission seen by the path at a hit on triangle tri (0 for analytic shapes) of an area light,
 * times share (1 but for probe_lamps' lamps). */
static void add_emission_hit(ctx_t *c, const path_t *p, const surface_t *sf, const light_t *l,
                             int li, size_t tri, double share)
{
    path_t direct;
    p = direct_lanes(c, p, &direct);
    double w = share;
    if (c->rs->integrator == INTEGRATOR_PATH && !p->specular) {
        const lights_at_t at = light_site_behind(p);
        double lp = lights_pdf(c->scene, &at, li, tri, p->dir, sf->p, sf->ng);
        w *= power_heuristic(p->bsdf_pdf, lp);
    }
    const int faces = lights_area_faces(l, sf->ng, vec3_neg(p->dir));
    /* A polarised lamp's Stokes vector along the ray, in the path's frame (§14.2). */
    double ls[4];
    const int polarised = p->polar && l->polarisation > 0.0;
    if (polarised)
        lights_stokes(l, vec3_neg(p->dir), p->polar_x, ls);
    for (int j = 0; j < p->n; j++)
        splat_polarised(c, p, j,
                        w * (faces ? light_value_lane(c, li, j, p->lambda[j]) *
                                         lights_area_image(l, sf->u, sf->v, p->lambda[j])
                                   : 0.0),
                        polarised ? ls : NULL);
}

static void add_environment(ctx_t *c, const path_t *p)
{
    path_t direct;
    p = direct_lanes(c, p, &direct);
    double w = 1.0;
    if (c->rs->integrator == INTEGRATOR_PATH && !p->specular) {
        const lights_at_t at = light_site_behind(p);
        double lp = 0.0;
        for (size_t i = 0; i < c->scene->nlights; i++)
            if (c->scene->lights[i].kind == LIGHT_INFINITE)
                lp += lights_pdf(c->scene, &at, (int)i, 0, p->dir, p->prev_p, p->dir);
        w = power_heuristic(p->bsdf_pdf, lp);
    }
    /* Image environments: each one's texel along the ray, once for all lanes. */
    size_t texel[LE_CACHE_LIGHTS];
    int nimg = 0;
    for (size_t i = 0; i < c->scene->nlights; i++)
        if (c->scene->lights[i].envmap) {
            nimg++;
            if (i < LE_CACHE_LIGHTS)
                texel[i] = lights_envmap_texel(&c->scene->lights[i], p->dir);
        }
    for (int j = 0; j < p->n; j++) {
        double le = environment_lane(c, j, p->lambda[j]);
        for (size_t i = 0; nimg && i < c->scene->nlights; i++) {
            const light_t *l = &c->scene->lights[i];
            if (!l->envmap)
                continue;
            size_t t = i < LE_CACHE_LIGHTS ? texel[i] : lights_envmap_texel(l, p->dir);
            le += lights_envmap_radiance(l, t, light_value_lane(c, (int)i, j, p->lambda[j]),
                                         p->lambda[j]);
        }
        splat(c, p, j, w * le);
    }
}

/* The shadow segment from o toward light sample ls (both ends offset off their surfaces by
 * the caller for o, here for the light's end): *dir and *tmax, 0 when it has no length. */
static int shadow_segment(vec3_t x, vec3_t o, const light_sample_t *ls, vec3_t *dir, double *tmax)
{
    *dir = ls->wi;
    *tmax = INFINITY;
    if (isinf(ls->dist))
        return 1;
    vec3_t target = ls->dist > 0 && ls->is_delta ? vec3_fma(x, ls->wi, ls->dist)
                                                 : geometry_offset(ls->p_light, ls->n_light, vec3_neg(ls->wi));
    vec3_t d = vec3_sub(target, o);
    *tmax = vec3_length(d);
    if (!(*tmax > 0.0))
        return 0;
    *dir = vec3_scale(d, 1.0 / *tmax);
    *tmax *= 1.0 - 1e-7;
    return 1;
}

/* The shadow ray from o over [0, tmax) along dir, starting in medium `medium`: visible (1)
 * or not, with each lane's transmittance in tr (all 1 without media). */
static int shadow_ray(ctx_t *c, const path_t *p, vec3_t o, vec3_t dir, double tmax, int medium,
                      double *tr)
{
    c->stats->rays++;
    if (c->media)
        return shading_transmittance(c->scene, o, dir, tmax, medium, p->lambda, p->n, &c->rng, tr);
    for (int j = 0; j < p->n; j++)
        tr[j] = 1.0;
    return !shading_occluded(c->scene, o, dir, 0.0, tmax);
}

/* Samples a light for next-event estimation at sf, whose shading normal there is n (the one
 * the bounce that follows keeps in prev_n), and traces its shadow ray: 1 with *ls and the
 * lanes' transmittances tr when the light is sampled and visible, 0 otherwise. accept(wi)
 * decides, before the shadow ray, whether the direction can contribute at all. */
static int light_visible(ctx_t *c, const path_t *p, const surface_t *sf, vec3_t n,
                         light_sample_t *ls, int (*accept)(const void *, vec3_t), const void *arg,
                         double *tr)
{
    double u[4];
    light_uniforms(c, u);
    const lights_at_t at = light_site(c, sf->p, n);
    if (!lights_sample(c->scene, &at, u, ls))
        return 0;
    if (!accept(arg, ls->wi) || !(ls->pdf > 0.0))
        return 0;
    /* Both ends of the shadow ray are offset off their surfaces (toward each other), so that
     * neither the shading point's surface nor the light's own surface blocks it. */
    vec3_t o = geometry_offset(sf->p, sf->ng, ls->wi);
    vec3_t dir;
    double tmax;
    if (!shadow_segment(sf->p, o, ls, &dir, &tmax))
        return 0;
    return shadow_ray(c, p, o, dir, tmax, scene_medium_after(sf, ls->wi, p->medium), tr);
}

typedef struct hemispheres {
    vec3_t n, g;
} hemispheres_t;

/* Above both the shading normal n and the geometric normal g. */
static int above_both(const void *arg, vec3_t wi)
{
    const hemispheres_t *h = arg;
    return vec3_dot(h->n, wi) > 0.0 && vec3_dot(h->g, wi) > 0.0;
}

/* Next-event estimation at a diffuse point with shading normal n and geometric normal g, both
 * facing the viewer. A light direction below either hemisphere contributes nothing (the
 * shading-normal rule of scatter's diffuse branch). */
static void direct_light(ctx_t *c, const path_t *p, const surface_t *sf, vec3_t n, vec3_t g,
                         const double *albedo)
{
    light_sample_t ls;
    const hemispheres_t hs = {n, g};
    double tr[LANES];
    if (!light_visible(c, p, sf, n, &ls, above_both, &hs, tr))
        return;
    /* A polarised light's Stokes vector meets the diffuse vertex's depolariser (§14, §14.2):
     * only its S0 reaches the carrier, so the light is splatted as unpolarised. */
    double cos_s = vec3_dot(n, ls.wi);
    double w = 1.0;
    if (!ls.is_delta && c->rs->integrator == INTEGRATOR_PATH)
        w = power_heuristic(ls.pdf, cos_s / PF_PI);
    for (int j = 0; j < p->n; j++) {
        double le = lights_sample_emission_of(c->scene, &ls,
                                              light_value_lane(c, ls.light, j, p->lambda[j]),
                                              p->lambda[j]);
        splat(c, p, j, w * albedo[j] / PF_PI * le * tr[j] * cos_s / ls.pdf);
    }
}

/* A direction on the side of the geometric surface that its local z says (the shading frame
 * and the real surface agree), so that no sampled or light direction passes through a mesh
 * where shading and geometric normals differ. */
typedef struct sides {
    const shading_frame_t *frame;
    vec3_t ng;
} sides_t;

static int sides_agree(const void *arg, vec3_t wi)
{
    const sides_t *s = arg;
    double zs = vec3_dot(wi, s->frame->z), zg = vec3_dot(wi, s->ng);
    return zs * zg > 0.0;
}

/* The pdf a BSDF-sampled direction had, from the lanes' own pdfs: with spectral MIS the lane
 * whose lobe samples is chosen with probability sel[k], so the direction's density is the
 * mixture sum_k sel[k] pdf_k (one-sample MIS, balance heuristic); without it (sel NULL) lane 0
 * sampled alone. */
static double lanes_pdf(const double *pdf, const double *sel, int n)
{
    if (!sel)
        return pdf[0];
    double sum = 0.0;
    for (int j = 0; j < n; j++)
        sum += sel[j] * pdf[j];
    return sum;
}

/* The lanes' selection probabilities for spectral MIS: in proportion to their throughput, so
 * that a lane that carries nothing (a secondary that an earlier dispersive event left with no
 * weight) is never the one that samples, and a path whose lanes have separated keeps
 * following the lane that carries it. Any choice made before the sample keeps the mixture
 * estimator unbiased. Returns 0 when no lane carries anything. */
static int lanes_select(const path_t *p, double *sel)
{
    double sum = 0.0;
    for (int j = 0; j < p->n; j++)
        sum += sel[j] = p->beta[j] > 0.0 ? p->beta[j] : 0.0;
    if (!(sum > 0.0) || !isfinite(sum))
        return 0;
    for (int j = 0; j < p->n; j++)
        sel[j] /= sum;
    return 1;
}

/* Next-event estimation at a surface with a non-delta bsdf b, the lanes weighted by MIS
 * against the BSDF sampling that lanes_pdf describes. */
/* Polarised transport at a bsdf/ model (docs/physics.md §14): q's carrier takes lane j's
 * bsdf_mueller for light arriving along -wi and leaving along wo (local: wo, wi_local; world:
 * wi), each lane's matrix in the s-p frames of its own microfacet re-expressed in the first
 * lane's (a rough dispersive refraction bends each lane through its own half vector). The
 * models without a matrix (diffuse, thin, layered) and directions no microfacet joins
 * depolarise. */
static void polar_bsdf(path_t *q, const bsdf_t *b, const shading_frame_t *fr, vec3_t wo,
                       vec3_t wi_local, vec3_t wi)
{
    mueller_t mm[LANES];
    polar_event_t ref;
    vec3_t ref_wm = vec3_make(0.0, 0.0, 0.0);
    int have = 0;
    const vec3_t k_in = vec3_neg(wi), k_out = vec3_neg(q->dir);
    for (int j = 0; j < q->n; j++) {
        vec3_t wm;
        if (!bsdf_mueller(b, j, wo, wi_local, &mm[j], &wm)) {
            mm[j] = mueller_identity(); /* a lane no microfacet joins carries f = 0 */
            continue;
        }
        if (!have) {
            ref = polar_event_interface(k_in, k_out, shading_to_world(fr, wm), q->polar_x);
            ref_wm = wm;
            have = 1;
        } else if (wm.x != ref_wm.x || wm.y != ref_wm.y || wm.z != ref_wm.z) {
            const polar_event_t ev =
                polar_event_interface(k_in, k_out, shading_to_world(fr, wm), q->polar_x);
            mm[j] = polar_event_rebase(&mm[j], &ev, &ref);
        }
    }
    if (have)
        polar_carrier_apply(q->polar_t, q->n, &q->polar_x, &ref, mm, 1);
    else
        polar_carrier_depolarise(q->polar_t, q->n, &q->polar_x, k_in);
}

static void direct_light_bsdf(ctx_t *c, const path_t *p, const surface_t *sf, const bsdf_t *b,
                              const shading_frame_t *fr, vec3_t wo_local, const double *sel)
{
    light_sample_t ls;
    const sides_t sd = {fr, sf->ng};
    double tr[LANES];
    if (!light_visible(c, p, sf, fr->z, &ls, sides_agree, &sd, tr))
        return;
    vec3_t wi = shading_to_local(fr, ls.wi);
    double f[LANES], pdf[LANES];
    walk_position(c, VD_LIGHT);
    bsdf_eval(b, wo_local, wi, &c->rng, f);
    double w = 1.0;
    if (!ls.is_delta && c->rs->integrator == INTEGRATOR_PATH) {
        walk_position(c, VD_LIGHT_PART);
        bsdf_pdf(b, wo_local, wi, &c->rng, pdf);
        w = power_heuristic(ls.pdf, lanes_pdf(pdf, sel, p->n));
    }
    const double cos_i = fabs(wi.z);
    /* With polarisation the light is scattered toward the path by the lobe's Mueller matrix:
     * a copy of the path's carrier takes it, and a polarised light's Stokes vector, travelling
     * along -wi, is measured in the frame the carrier is left in (§14.2). */
    const path_t *q = p;
    path_t polarised;
    double lstokes[4];
    const double *lsp = NULL;
    if (p->polar) {
        path_copy(&polarised, p);
        polar_bsdf(&polarised, b, fr, wo_local, wi, ls.wi);
        q = &polarised;
        const light_t *l = &c->scene->lights[ls.light];
        if (l->polarisation > 0.0) {
            lights_stokes(l, vec3_neg(ls.wi), q->polar_x, lstokes);
            lsp = lstokes;
        }
    }
    for (int j = 0; j < p->n; j++) {
        if (!(f[j] > 0.0))
            continue;
        double le = lights_sample_emission_of(c->scene, &ls,
                                              light_value_lane(c, ls.light, j, p->lambda[j]),
                                              p->lambda[j]);
        splat_polarised(c, q, j, w * f[j] * cos_i * le * tr[j] / ls.pdf, lsp);
    }
}

/* The caustic store's share at a diffuse point with geometric normal g facing the viewer:
 * Lambertian radiance (rho / pi) E_b from the store's irradiance (photon_store.h),
 * for each lane the bucket its light goes to. Added at every diffuse vertex of the path, where
 * the store replaces exactly the paths that leave that vertex through specular surfaces to a
 * light (trace does not count them). At a vertex behind a diffuse bounce or a medium
 * scattering, path tracing would find the store's light only by reaching the caustic and then
 * the light through the glass: missing for a delta light, and from a small one a tail too heavy
 * to converge (docs/physics.md §5, the path-space split). */
static void caustic_light(ctx_t *c, const path_t *p, const hit_t *h, const surface_t *sf,
                          vec3_t g, const double *albedo)
{
    if (!photon_store_irradiance(c->photons, h, sf->p, g, c->irradiance))
        return;
    for (int j = 0; j < p->n; j++) {
        int b = p->bucket[j] >= 0 ? p->bucket[j] : spectral_table_index(c->table, p->lambda[j]);
        if (b >= 0)
            splat(c, p, j, albedo[j] / PF_PI * c->irradiance[b]);
    }
}

/* The caustic store's share at a glossy receiver (any surface scatter_bsdf shades), from a
 * store that keeps directions: the photon density estimate with the receiver's BSDF inside
 * the sum (photon_store_gather), L_j = scale x sum over the photons of lane j's bucket of
 * f_j(wo, -dir) power. Added at the path's first non-specular surface vertex;
 * scatter_bsdf then lets the chain count from here, so that the paths it would find the other
 * way (L S+ G S* E: the next vertex's emission) are not counted twice. f is bsdf_eval's: the
 * coated models' stochastic estimate, unbiased, and without a smooth coat's delta reflection,
 * which the path samples as specular and carries on.
 *
 * A caustic puts hundreds of photons in a gather disk, and a coated receiver's evaluation is a
 * random walk in its layers (a caustic-glass render took 15 times as long evaluating every
 * one). So the sum is estimated from about GLOSSY_GATHER_EVALS of them, shared out equally
 * between the lanes' buckets (a group: the lanes of one bucket), so that every lane's
 * estimate has picks of its own and the colour stays smooth. A first pass over the disk sums,
 * per group, W_g = sum of power x g over the photons that can count (of the group's bucket, on
 * the viewer's sides), g = bsdf_guide(wo, wi) a cheap positive stand-in for f; a second picks
 * M_g of them by systematic sampling in proportion to power x g -- the m-th pick where the
 * group's running sum passes (m + xi) W_g / M_g -- and each pick adds W_g / (M_g g) f_j to the
 * group's lanes. A photon is picked M_g power g / W_g times on average, so the estimate is
 * unbiased for any positive g (importance sampling of the sum); g = 1 (power alone) for all
 * but the coated models, whose coat lobe makes f vary tenfold between photons arriving from
 * different facets of a glass (docs/performance.md, caustic-glass). A group with no more
 * photons than M_g evaluates each once. */
#define GLOSSY_GATHER_EVALS 4
/* The first pass keeps the photons that can count, up to this many (40 bytes each, on the
 * stack; a white photon is kept once per group), so that the second picks from them instead of
 * searching the map again: the search was a fifth of caustic-glass's camera pass
 * (docs/performance.md, "caustic-glass"). A disk holding more is searched again, which visits the
 * same photons in the same order. */
#define GLOSSY_KEEP 1024

typedef struct glossy_group {
    int bucket;
    int count;         /* photons that can count (pass 0) */
    double total;      /* their power W_g (pass 0) */
    double running;    /* the running sum of power (pass 1) */
    double step, next; /* W_g / M_g and the next pick's target (pass 1; step 0: every photon) */
} glossy_group_t;

typedef struct glossy_kept {
    vec3_t wi; /* the direction the photon's light comes from, -dir */
    double power;
    double guide; /* bsdf_guide at wi */
    int group;
} glossy_kept_t;

typedef struct glossy_gather {
    ctx_t *c;
    const path_t *p;
    const bsdf_t *b;
    const shading_frame_t *fr;
    sides_t sd;
    vec3_t wo;
    int group[LANES]; /* each lane's group */
    int ngroups;
    glossy_group_t groups[LANES];
    double sum[LANES];
    int pass;  /* 0: summing W_g, 1: evaluating */
    int nkept; /* photons kept by pass 0; > GLOSSY_KEEP: too many, pass 1 searches again */
    glossy_kept_t *kept; /* [GLOSSY_KEEP], not zeroed: only the first nkept are read */
} glossy_gather_t;

/* Pass 1 for a photon of group gi that can count: the picks that fall on it, if any, add
 * f(wo, wi) times their weight to the group's lanes. */
static void glossy_pick(glossy_gather_t *gg, int gi, vec3_t wi_world, double power, double guide)
{
    glossy_group_t *g = &gg->groups[gi];
    double weight = power;
    if (g->step > 0.0) {
        double lo = g->running;
        g->running += power * guide;
        int picks = 0;
        while (g->next < g->running && g->next >= lo && picks < GLOSSY_GATHER_EVALS) {
            picks++;
            g->next += g->step;
        }
        if (picks == 0)
            return;
        weight = picks * g->step / guide;
    }
    double f[LANES];
    bsdf_eval(gg->b, gg->wo, shading_to_local(gg->fr, wi_world), &gg->c->rng, f);
    for (int j = 0; j < gg->p->n; j++)
        if (gg->group[j] == gi && f[j] > 0.0)
            gg->sum[j] += f[j] * weight;
}

/* A photon's share in group gi: pass 0 counts and keeps it, pass 1 places the picks. */
static void glossy_take(glossy_gather_t *gg, int gi, vec3_t wi_world, double power, double guide)
{
    if (gg->pass == 1) {
        glossy_pick(gg, gi, wi_world, power, guide);
        return;
    }
    glossy_group_t *g = &gg->groups[gi];
    g->count++;
    g->total += power * guide;
    if (gg->nkept < GLOSSY_KEEP)
        gg->kept[gg->nkept] =
            (glossy_kept_t){.wi = wi_world, .power = power, .guide = guide, .group = gi};
    if (gg->nkept <= GLOSSY_KEEP)
        gg->nkept++;
}

static void glossy_photon(void *user, vec3_t dir, int bucket, double power)
{
    glossy_gather_t *gg = user;
    /* A white photon (photon_map.h) counts in every group, with its power in that group's
     * bucket; a coloured one in its bucket's group only. */
    const double *white = bucket < 0 ? photon_store_white_spectrum(gg->c->photons, bucket) : NULL;
    int gi = 0;
    while (!white && gi < gg->ngroups && gg->groups[gi].bucket != bucket)
        gi++;
    /* The photon's light comes from -dir; a direction the geometric surface and the shading
     * frame put on different sides would pass through the mesh (as in next-event estimation). */
    const vec3_t wi_world = vec3_neg(dir);
    if ((!white && (bucket < 0 || gi == gg->ngroups)) || !(power > 0.0) ||
        !sides_agree(&gg->sd, wi_world))
        return;
    /* A white photon is picked by power alone (g = 1): every photon of the disk is in every
     * group, and the coat lobe's guide for each took 40 % more CPU than the picks it improves
     * (docs/performance.md, "caustic-glass: white photons"). */
    const double guide =
        white ? 1.0 : bsdf_guide(gg->b, gg->wo, shading_to_local(gg->fr, wi_world));
    if (!(guide > 0.0) || !isfinite(guide))
        return;
    if (!white) {
        glossy_take(gg, gi, wi_world, power, guide);
        return;
    }
    for (gi = 0; gi < gg->ngroups; gi++) {
        const int bk = gg->groups[gi].bucket;
        const double pw = bk >= 0 ? power * white[bk] : 0.0;
        if (pw > 0.0)
            glossy_take(gg, gi, wi_world, pw, guide);
    }
}

static void caustic_light_bsdf(ctx_t *c, const path_t *p, const surface_t *sf, const bsdf_t *b,
                               const shading_frame_t *fr, vec3_t wo_local)
{
    glossy_kept_t kept[GLOSSY_KEEP];
    glossy_gather_t gg = {
        .c = c, .p = p, .b = b, .fr = fr, .sd = {fr, sf->ng}, .wo = wo_local, .kept = kept};
    for (int j = 0; j < p->n; j++) {
        int bk = p->bucket[j] >= 0 ? p->bucket[j] : spectral_table_index(c->table, p->lambda[j]);
        int gi = 0;
        while (gi < gg.ngroups && gg.groups[gi].bucket != bk)
            gi++;
        if (gi == gg.ngroups)
            gg.groups[gg.ngroups++] = (glossy_group_t){.bucket = bk};
        gg.group[j] = gi;
        gg.sum[j] = 0.0;
    }
    double scale;
    if (!photon_store_gather(c->photons, sf->p, sf->ng, glossy_photon, &gg, &scale))
        return;
    /* One jitter for every group: each group's estimate is unbiased on its own. */
    const double jitter = draw1(c, VD_GATHER);
    const int per_group = GLOSSY_GATHER_EVALS / gg.ngroups > 0 ? GLOSSY_GATHER_EVALS / gg.ngroups : 1;
    int any = 0;
    for (int gi = 0; gi < gg.ngroups; gi++) {
        glossy_group_t *g = &gg.groups[gi];
        if (!(g->total > 0.0) || !isfinite(g->total)) {
            g->bucket = -2; /* takes no photon in the second pass */
            continue;
        }
        any = 1;
        if (g->count > per_group) {
            g->step = g->total / per_group;
            g->next = jitter * g->step;
        }
    }
    if (!any)
        return;
    gg.pass = 1;
    if (gg.nkept <= GLOSSY_KEEP) {
        for (int i = 0; i < gg.nkept; i++)
            if (gg.groups[gg.kept[i].group].bucket != -2)
                glossy_pick(&gg, gg.kept[i].group, gg.kept[i].wi, gg.kept[i].power,
                            gg.kept[i].guide);
    } else {
        photon_store_gather(c->photons, sf->p, sf->ng, glossy_photon, &gg, &scale);
    }
    for (int j = 0; j < p->n; j++)
        if (gg.sum[j] > 0.0)
            splat(c, p, j, gg.sum[j] * scale);
}

/* Reflect-or-refract choice: with Whitted both branches are followed (the second pushed on
 * the stack); otherwise one is chosen with probability prob_reflect and the weights divided
 * by it. Returns 1 to take the reflection, 0 the refraction; *scale is the factor to apply
 * to the chosen branch (1/probability, or 1 for Whitted). For Whitted the refraction branch
 * is returned to the caller and the reflection pushed, when there is room. */
static int choose_reflect(ctx_t *c, double prob_reflect, double *scale)
{
    if (prob_reflect >= 1.0) {
        *scale = 1.0;
        return 1;
    }
    if (prob_reflect <= 0.0) {
        *scale = 1.0;
        return 0;
    }
    double u = draw1(c, VD_REFLECT);
    if (u < prob_reflect) {
        *scale = 1.0 / prob_reflect;
        return 1;
    }
    *scale = 1.0 / (1.0 - prob_reflect);
    return 0;
}

static void start_bounce(path_t *p, const surface_t *h, vec3_t dir, int specular, double pdf)
{
    p->medium = scene_medium_after(h, dir, p->medium);
    p->prev_p = h->p;
    p->prev_n = h->ns;
    p->org = geometry_offset(h->p, h->ng, dir);
    p->dir = dir;
    p->specular = specular;
    p->bsdf_pdf = pdf;
}

/* Where a smooth dielectric event happens, for its Mueller matrices: the normal the
 * directions were computed about, the side the path comes from, the lanes' indices (n[0] for
 * every lane unless per_lane) and the material (its coating). */
typedef struct dielectric_site {
    vec3_t nrm;
    int entering;
    const double *n;
    int per_lane;
    const material_t *m;
} dielectric_site_t;

/* Polarised transport at a smooth dielectric (docs/physics.md §14): p's carrier takes the
 * branch leaving along out (reflected or refracted) -- bsdf/delta.h's normalised Mueller matrix
 * per lane, or one for every lane -- in the s-p frames about the site's normal. Called before
 * start_bounce, while p->dir is still the direction the path arrived along. */
static void polar_dielectric(path_t *p, const dielectric_site_t *d, vec3_t out, bool reflect)
{
    const material_t *m = d->m;
    const delta_film_t film = {m->film_thickness, &m->film_ior};
    const delta_film_t *f = m->film_thickness > 0.0 ? &film : NULL;
    mueller_t mm[LANES];
    const int count = d->per_lane ? p->n : 1;
    for (int j = 0; j < count; j++)
        mm[j] =
            delta_dielectric_mueller(out, d->nrm, d->entering, d->n[j], p->lambda[j], f, reflect);
    const polar_event_t ev =
        polar_event_interface(vec3_neg(out), vec3_neg(p->dir), d->nrm, p->polar_x);
    polar_carrier_apply(p->polar_t, p->n, &p->polar_x, &ev, mm, d->per_lane);
}

/* Ray splitting at dense stones (render_settings_t.split_depth). Light enters a stone of index
 * 2.4 with T about 0.83, stays by total internal reflection and leaves where a facet lets it:
 * both branches of such an event carry light of the same order (the crown's reflection of a lamp
 * and the fire inside), so a random choice between them makes a facet white in one sample and
 * dark in the next. Following both, each weighted by its Fresnel factor, removes that noise at
 * the cost of a second path (with roulette told of it, split_dense, which measured the larger
 * part: docs/performance.md, "The demo"); in ordinary glass (R about
 * 0.04) the reflected branch rarely pays for its path, so only materials of index n_d >=
 * SPLIT_MIN_IOR split, and only at a path's first split_depth such events, which bounds the
 * branches of one camera sample by 2^split_depth (each refraction's hero lanes split too:
 * split_lanes). The branches draw the path's later dimensions as Whitted's do, so the image
 * stays a function of (seed, pixel, sample); each branch is an unbiased estimate of its share,
 * so their sum is one of the whole. Whitted splits every event already. */
#define SPLIT_MIN_IOR 1.9
#define SPLIT_LAMBDA_D 587.56

/* Whether material m is a dense stone that splitting applies to (render_settings_t.split_depth
 * > 0; the path integrator only: Whitted splits everything, and the thesis's simple path tracer
 * stays as it is written). At such a stone Russian roulette is also told
 * which of an event's factors are not losses (path_t.rr_scale): a split branch's Fresnel share
 * (the branch is part of the light, not light lost: rouletted by its weight it would be killed
 * with probability 1 - R and its survivors scaled by 1/R, the random choice's noise again) and
 * the refraction's (n_i / n_t)^2 (radiance compressed by 1/n^2 inside the stone comes back at
 * the exit; pbrt-v4's etaScale). A lossless stone then never ends a path by roulette. */
static int split_dense(const ctx_t *c, const material_t *m)
{
    return c->rs->split_depth > 0 && c->rs->integrator == INTEGRATOR_PATH &&
           ior_eval(&m->ior, SPLIT_LAMBDA_D) >= SPLIT_MIN_IOR;
}

/* Whether the event at a dense stone splits, counted on p when it does. */
static int split_here(path_t *p, int dense, int depth)
{
    if (!dense || p->splits >= depth)
        return 0;
    p->splits++; /* before the push, so that both branches count this event */
    return 1;
}

/* Pushes a copy of p on the reflected branch of a delta event (Whitted follows both branches):
 * its lanes weighted by w (one factor) or by the hero event's per-lane factors, its roulette
 * scale divided by rr_share (split_dense; 1 elsewhere). 0 when pushed. */
static int push_reflection(ctx_t *c, const path_t *p, const surface_t *h, vec3_t refl, double w,
                           const delta_dielectric_t *lanes, const dielectric_site_t *site,
                           double rr_share)
{
    path_t r;
    path_copy(&r, p);
    r.rr_scale /= rr_share;
    for (int j = 0; j < r.n; j++)
        r.beta[j] *= lanes ? delta_dielectric_reflect_lane(lanes, j, false) : w;
    if (r.polar)
        polar_dielectric(&r, site, refl, true);
    start_bounce(&r, h, refl, 1, 0.0);
    r.depth++;
    return push(c, &r);
}

/* The refraction of a hero event whose branches are both followed (split_here), lane by lane:
 * lanes 1..n-1 of p, each with its own index n[j], normal and refracted direction, are pushed
 * as monochrome paths weighted by their own transmission, so that the caller's lane 0 goes on
 * without the lane count's factor (the hero estimator's sum over the tuple, each lane at its own
 * wavelength, instead of the hero's alone). Lanes totally reflected carry nothing here (their
 * reflection went with the reflected branch, R_j = 1). Returns -1, pushing nothing, when the
 * stack has no room for them: the caller then ends the secondaries as usual. */
static int split_lanes(ctx_t *c, const path_t *p, const surface_t *h, const material_t *m,
                       const double *n, int entering)
{
    if (c->top + p->n - 1 > STACK_MAX)
        return -1;
    for (int j = 1; j < p->n; j++) {
        vec3_t nrm = specular_normal(h, p->dir, delta_eta_ratio(n[j], entering), NULL);
        delta_dielectric_t e;
        delta_dielectric_make(p->dir, nrm, entering, &n[j], 1, BSDF_RADIANCE, &e);
        if (!e.refracts || !(p->beta[j] > 0.0))
            continue;
        path_t q;
        path_copy(&q, p);
        q.n = 1;
        q.lambda[0] = p->lambda[j];
        q.pdf[0] = p->pdf[j];
        q.bucket[0] = p->bucket[j];
        const double t = delta_dielectric_weight(&e, false, 1.0);
        q.beta[0] = p->beta[j] * t;
        q.rr_scale = p->rr_scale / t; /* a dense stone's event: split_dense */
        q.mono = 1;
        q.dispersed = 1;
        if (q.polar) {
            q.polar_t[0] = p->polar_t[j];
            const dielectric_site_t site = {nrm, entering, &n[j], 0, m};
            polar_dielectric(&q, &site, e.refract, false);
        }
        start_bounce(&q, h, e.refract, 1, 0.0);
        q.depth++; /* the caller counts the current path's bounce */
        push(c, &q);
    }
    return 0;
}

/* Fan-out lanes that cannot go on together (a coating's or a crystal's event depends on the
 * wavelength): one lane, picked uniformly, goes on alone, weighted by the lane count, with its
 * Stokes carrier. */
static void fanout_pick_one(ctx_t *c, path_t *p)
{
    const int k = (int)fmin(p->n - 1, floor(draw1(c, VD_FAN_PICK) * p->n));
    p->lambda[0] = p->lambda[k];
    p->bucket[0] = p->bucket[k];
    p->pdf[0] = p->pdf[k];
    p->beta[0] = p->beta[k] * p->n;
    if (p->polar)
        p->polar_t[0] = p->polar_t[k];
    p->n = 1;
    p->mono = 1;
}

/* Smooth dielectric: the physics is bsdf/delta.h's (radiance mode); this is the camera
 * pass's policy for its branches -- one chosen at random, or both (Whitted, and a path's first
 * events at a dense stone: split_here), and at a
 * dispersive interface the hero's termination of the secondaries or the thesis's fan-out.
 * Returns 0 to continue the path, 1 when it ends (its sub-paths were pushed or it carries
 * nothing). */
static int scatter_dielectric(ctx_t *c, path_t *p, const surface_t *h, const material_t *m)
{
    const int whitted = c->rs->integrator == INTEGRATOR_WHITTED;
    /* Which medium the path is in comes from the geometric surface alone. */
    const int entering = vec3_dot(p->dir, h->ng) < 0.0;
    const int coated = m->film_thickness > 0.0;
    if (coated && m->dispersive && !p->mono && c->rs->dispersion == DISPERSION_FANOUT) {
        /* A coating's reflectance varies with wavelength (interference), which the fan-out's
         * polychrome decision at one mean index cannot carry: one lane, picked uniformly,
         * goes on weighted by the lane count (its wavelength keeps its bucket's uniform
         * density, as at a dispersive lens: lens_ray), and the event is the coated hero's. */
        c->stats->dispersive++;
        fanout_pick_one(c, p);
    }
    double n[LANES];
    n[0] = ior_eval(&m->ior, p->lambda[0]);
    int shading;
    vec3_t nrm = specular_normal(h, p->dir, delta_eta_ratio(n[0], entering), &shading);

    if (!m->dispersive || p->mono || c->rs->dispersion == DISPERSION_HERO) {
        /* One index for every lane (constant glass, or a path that is already monochrome),
         * or the hero wavelength deciding: reflection keeps every lane (its direction does
         * not depend on wavelength), weighted by R(lambda_j)/R(hero); refraction sends each
         * lane its own way, so the secondaries end and the hero's weight is multiplied by
         * the lane count (pbrt-v4 TerminateSecondary), so only the hero is splatted from
         * here on (the trap of docs/physics.md §4.5). */
        const int hero = m->dispersive && !p->mono;
        if (hero) {
            c->stats->dispersive++;
            for (int j = 1; j < p->n; j++)
                n[j] = ior_eval(&m->ior, p->lambda[j]);
        } else if (coated) {
            for (int j = 1; j < p->n; j++)
                n[j] = n[0];
        }
        /* A coating gives every lane its own reflectance (interference), dispersive or not. */
        const int lanes = hero || coated;
        delta_dielectric_t e;
        delta_dielectric_make(p->dir, nrm, entering, n, lanes ? p->n : 1, BSDF_RADIANCE, &e);
        if (coated) {
            const delta_film_t film = {m->film_thickness, &m->film_ior};
            delta_dielectric_coat(&e, p->dir, nrm, entering, n, p->lambda, &film);
        }
        const dielectric_site_t site = {nrm, entering, n, lanes, m};
        const double R = e.prob_reflect;
        const int dense = split_dense(c, m);
        int both = 0;
        if (R > 0.0 && R < 1.0 &&
            (whitted ? c->branches < c->max_branches : split_here(p, dense, c->rs->split_depth)))
            both = push_reflection(c, p, h, e.reflect, delta_dielectric_weight(&e, true, 1.0),
                                   lanes ? &e : NULL, &site,
                                   dense ? delta_dielectric_weight(&e, true, 1.0) : 1.0) == 0;
        double scale = 1.0;
        if (!both && choose_reflect(c, R, &scale)) {
            for (int j = 0; j < p->n; j++)
                p->beta[j] *= lanes ? delta_dielectric_reflect_lane(&e, j, true)
                                    : delta_dielectric_weight(&e, true, scale);
            if (p->polar)
                polar_dielectric(p, &site, e.reflect, true);
            start_bounce(p, h, e.reflect, 1, 0.0);
            return 0;
        }
        /* At a dense stone roulette is told lane 0's factor (split_dense): T (n_i/n_t)^2 on a
         * split, (n_i/n_t)^2 after a random choice. */
        if (dense)
            p->rr_scale /= lanes ? delta_dielectric_transmit_lane(&e, 0, scale)
                                 : delta_dielectric_weight(&e, false, scale);
        if (hero) {
            /* A split event (both branches followed, scale 1) refracts every lane its own way
             * (split_lanes); elsewhere the secondaries end. */
            const int each = both && !whitted && split_lanes(c, p, h, m, n, entering) == 0;
            p->beta[0] *= delta_dielectric_transmit_lane(&e, 0, scale) * (each ? 1 : p->n);
            p->n = 1;
            p->mono = 1;
            p->dispersed = 1;
        } else if (coated) {
            for (int j = 0; j < p->n; j++)
                p->beta[j] *= delta_dielectric_transmit_lane(&e, j, scale);
        } else {
            const double t = delta_dielectric_weight(&e, false, scale);
            for (int j = 0; j < p->n; j++)
                p->beta[j] *= t;
        }
        if (p->polar)
            polar_dielectric(p, &site, e.refract, false);
        start_bounce(p, h, e.refract, 1, 0.0);
        return 0;
    }

    /* The thesis's fan-out over the framebuffer buckets (5.3-5.4). */
    c->stats->dispersive++;
    const int nb = p->n;
    double centres[LANES], ones[LANES], lam[LANES];
    fanout_sample_t split[LANES];
    for (int i = 0; i < nb; i++) {
        centres[i] = p->lambda[i];
        ones[i] = 1.0;
    }
    double shift = draw1(c, VD_FAN_JITTER) - 0.5;
    if (fanout_split(centres, ones, nb, shift, split, NULL))
        return 1;
    for (int i = 0; i < nb; i++)
        lam[i] = split[i].lambda_nm;
    /* The monochrome rays refract at slightly different angles: if one of them would cross
     * the geometric surface the wrong way with the shading normal, the whole fan uses the
     * geometric normal (specular_normal's rule). */
    delta_fan_t fan;
    vec3_t fan_nrm = nrm;
    if (delta_fan_make(p->dir, nrm, &m->ior, lam, nb, BSDF_RADIANCE, &fan))
        return 1;
    if (shading) {
        double cg = vec3_dot(p->dir, h->ng);
        int bad = 0;
        for (int i = 0; i < nb; i++)
            bad |= !fan.rays[i].tir && vec3_dot(fan.rays[i].dir, h->ng) * cg <= 0.0;
        if (bad && delta_fan_make(p->dir, h->ng, &m->ior, lam, nb, BSDF_RADIANCE, &fan))
            return 1;
        if (bad)
            fan_nrm = h->ng;
    }
    double RP = fan.poly.reflectance, TP = fan.poly.transmittance;
    /* With polarisation each lane's reflection is its own index's Mueller matrix (the scalar
     * weight stays the polychrome R_P); a fan-out ray's refraction is its wavelength's. */
    if (p->polar)
        for (int j = 1; j < nb; j++)
            n[j] = ior_eval(&m->ior, p->lambda[j]);
    const dielectric_site_t fsite = {fan_nrm, entering, n, 1, m};
    /* A split fan-out event does not tell roulette its shares (split_dense): not measured. */
    int both = 0;
    if (RP > 0.0 && RP < 1.0 &&
        (whitted ? c->branches < c->max_branches
                 : split_here(p, split_dense(c, m), c->rs->split_depth)))
        both = push_reflection(c, p, h, fan.reflect, RP, NULL, &fsite, 1.0) == 0;
    double scale = 1.0;
    int reflect = both ? 0 : choose_reflect(c, RP, &scale);
    if (reflect) {
        for (int j = 0; j < p->n; j++)
            p->beta[j] *= RP * scale;
        if (p->polar)
            polar_dielectric(p, &fsite, fan.reflect, true);
        start_bounce(p, h, fan.reflect, 1, 0.0);
        return 0;
    }
    if (!(TP > 0.0))
        return 1;
    /* Refraction of the polychrome ray: monochrome ray i carries bucket i's energy split
     * (1-|S|, |S|) with its neighbour, with the Fresnel weight of delta_fan_weight; the
     * reflect-or-refract choice already divided by (1 - R_P).
     * All N rays are followed at the path's first dispersive refraction; at later ones (or
     * if the branch stack is too full) one ray, chosen uniformly and weighted by N. */
    int pick = -1;
    double pick_scale = 1.0;
    if (p->dispersed || c->top + nb > STACK_MAX) {
        pick = (int)fmin(nb - 1, floor(draw1(c, VD_FAN_PICK) * nb));
        pick_scale = nb;
    }
    path_t base;
    path_copy(&base, p);
    int have_current = 0;
    for (int i = 0; i < nb; i++) {
        if ((pick >= 0 && i != pick) || fan.rays[i].tir || !(fan.rays[i].transmittance > 0.0))
            continue;
        double w = delta_fan_weight(&fan, i, scale, pick_scale);
        path_t *q = have_current ? &c->stack[c->top++] : p;
        memcpy(q, &base, offsetof(path_t, lambda));
        q->n = 2;
        q->lambda[0] = q->lambda[1] = lam[i];
        q->bucket[0] = split[i].bucket[0];
        q->bucket[1] = split[i].bucket[1];
        q->beta[0] = base.beta[i] * split[i].energy[0] * w;
        q->beta[1] = base.beta[i] * split[i].energy[1] * w;
        q->pdf[0] = q->pdf[1] = 1.0;
        q->mono = 1;
        q->dispersed = 1;
        if (base.polar) {
            q->polar_t[0] = q->polar_t[1] = base.polar_t[i];
            const double ni = ior_eval(&m->ior, lam[i]);
            const dielectric_site_t rsite = {fan_nrm, entering, &ni, 0, m};
            polar_dielectric(q, &rsite, fan.rays[i].dir, false);
        }
        start_bounce(q, h, fan.rays[i].dir, 1, 0.0);
        if (have_current)
            q->depth++; /* the caller counts the current path's bounce */
        have_current = 1;
    }
    return have_current ? 0 : 1;
}

/* A uniaxial crystal (render/crystal_scatter.h): fan-out lanes go on as one lane picked
 * uniformly (as at a coated dispersive glass); hero lanes end at a refraction whose indices
 * differ; with polarisation the carrier takes the branch's Mueller matrix. Returns 0 to
 * continue the path, 1 when it ends. */
static int scatter_crystal(ctx_t *c, path_t *p, const surface_t *h, const material_t *m,
                           vec3_t axis)
{
    /* A coherent crystal keeps every lane on its one ray (render/crystal_coherent.h). */
    const int coherent = material_uniaxial_of(m)->coherent && p->polar;
    if (p->n > 1 && !p->mono && c->rs->dispersion == DISPERSION_FANOUT && !coherent)
        fanout_pick_one(c, p);
    vec3_t dir;
    int end = 0;
    crystal_polar_t pol = {.x = p->polar_x, .coh = coherent ? &c->coh : NULL};
    if (crystal_scatter(m, h, axis, p->org, p->dir, &p->wave, p->n, p->lambda, p->beta,
                        BSDF_RADIANCE, draw1(c, VD_REFLECT), &dir, &end, p->polar ? &pol : NULL))
        return 1;
    if (end) {
        p->n = 1;
        p->mono = 1;
        p->dispersed = 1;
    }
    /* Polarised transport: the branch's Mueller matrix, lane 0's for every lane (a crystal's
     * lanes differ only in magnitudes, docs/physics.md §15). */
    if (p->polar && !pol.pending)
        polar_carrier_apply(p->polar_t, p->n, &p->polar_x, &pol.ev, pol.lanes ? pol.lanes : &pol.m,
                            pol.lanes != NULL);
    start_bounce(p, h, dir, 1, 0.0);
    return 0;
}

/* The photon integrator's split counts only the smooth mirrors and glass that the photon pass
 * follows as specular (L S+ D); any other surface breaks the chain, so that light through
 * it is path traced and never both gathered and found (docs/rendering.md). */
#define CHAIN_BROKEN (-(1 << 20))
/* specular_since_diffuse after a medium scattering point that gathered the volume photons
 * (volume_caustic), plus the smooth events since: that point takes the store's L S+ V light at
 * any depth of the path, so light reached from it through mindepth or more smooth surfaces is
 * the store's, whatever came before. */
#define CHAIN_VOLUME (1 << 20)

/* Defined below scatter_bsdf, which it serves (and scatter_subsurface). */
static int scatter_with(ctx_t *c, path_t *p, const surface_t *sf, const bsdf_t *b, int gather,
                        int *sampled);

/* The lane that samples under spectral MIS: lane j with probability sel[j] for the uniform u,
 * never a lane of probability 0. */
static int lanes_pick(const double *sel, int n, double u)
{
    double acc = 0.0;
    int hero = n - 1;
    for (int j = 0; j < n; j++)
        if (u < (acc += sel[j]) && sel[j] > 0.0) {
            hero = j;
            break;
        }
    while (hero > 0 && !(sel[hero] > 0.0))
        hero--;
    return hero;
}

/* The material's model at sf for the path's lanes, roughened when regularize applies. */
static void path_bsdf(const path_t *p, const surface_t *sf, const material_t *m, int regularized,
                      bsdf_t *b)
{
    shading_bsdf(m, sf, p->lambda, p->n, BSDF_RADIANCE, b);
    if (regularized)
        regularize_bsdf(b);
}

/* Every surface that is not Lambertian, a smooth mirror or smooth glass: its bsdf/ model,
 * with next-event estimation where it has a non-delta lobe. Returns 0 to continue the path,
 * 1 when it ends.
 *
 * Lanes: the direction is sampled from one lane's lobe. With spectral MIS (the default) that
 * lane is chosen at random in proportion to the lanes' throughputs (lanes_select), so the
 * direction's density is the mixture sum_k sel_k pdf_k(wi) of the lanes' densities, and lane j
 * is weighted f_j |cos| / sum_k sel_k pdf_k: every lane keeps a bounded weight even where the
 * lobes differ (a rough dispersive dielectric refracts each wavelength into its own lobe),
 * instead of ending. With "spectralmis" false,
 * a surface whose lobes differ ends the secondary lanes as pbrt-v4 does (the hero, lane 0,
 * carries n times its weight). Lanes whose lobes agree give the same numbers either way. */
static int scatter_bsdf(ctx_t *c, path_t *p, const surface_t *sf, const material_t *m,
                        int regularized)
{
    bsdf_t b;
    path_bsdf(p, sf, m, regularized, &b);
    return scatter_with(c, p, sf, &b, 1, NULL);
}

/* scatter_bsdf with the model b at sf; gather 0 keeps the caustic store's photons away (none
 * are stored where they cannot arrive); *sampled (when not NULL) gets the sample's flags. */
static int scatter_with(ctx_t *c, path_t *p, const surface_t *sf, const bsdf_t *b, int gather,
                        int *sampled)
{
    const vec3_t wo_world = vec3_neg(p->dir);
    const shading_frame_t fr = shading_frame_make(sf, wo_world);
    const vec3_t wo = shading_to_local(&fr, wo_world);
    if (!(wo.z != 0.0))
        return 1;
    /* The coated models' sample gives each lane an unbiased weight f / pdf, but their pdf is
     * pbrt-v4's approximation for MIS, not a density: their lanes cannot be mixed, and a
     * dispersive coat ends the secondaries as pbrt-v4 does. */
    const int layered = bsdf_pdf_is_estimate(b);
    const int terminate = (!c->rs->spectral_mis || layered) && p->n > 1 && bsdf_lanes_disperse(b);
    double sel_lanes[LANES];
    const double *sel = NULL;
    if (!terminate && !layered && p->n > 1) {
        if (!lanes_select(p, sel_lanes))
            return 1;
        sel = sel_lanes;
    }
    const int delta = bsdf_is_specular(b);
    if (!delta && c->rs->integrator != INTEGRATOR_SIMPLEPATH)
        direct_light_bsdf(c, p, sf, b, &fr, wo, sel);
    /* The glossy receiver's photons, at the path's first non-specular vertex, as caustic_light
     * at a diffuse one; only a store with directions has them (photon.c). */
    const int gathers = gather && c->glossy_photons && !delta && p->surface_bounces == 0;
    if (gathers)
        caustic_light_bsdf(c, p, sf, b, &fr, wo);
    if (!delta && c->rs->integrator == INTEGRATOR_WHITTED)
        return 1;
    const int hero = sel ? lanes_pick(sel, p->n, draw1(c, VD_LANE)) : 0;
    double uc = draw1(c, VD_LOBE), ud[2];
    draw2(c, VD_DIRECTION, ud);
    bsdf_sample_t bs;
    walk_position(c, VD_LOBE);
    if (!bsdf_sample(b, wo, hero, uc, ud[0], ud[1], &c->rng, &bs))
        return 1;
    const vec3_t wi = shading_to_world(&fr, bs.wi);
    const sides_t sd = {&fr, sf->ng};
    if (!sides_agree(&sd, wi))
        return 1;
    const double cos_i = fabs(bs.wi.z);
    double pdf = lanes_pdf(bs.pdf, sel, p->n);
    if (!(pdf > 0.0))
        return 1;
    const int specular = (bs.flags & BSDF_SPECULAR) != 0;
    if (terminate) {
        p->beta[0] *= bs.f[0] * cos_i / bs.pdf[0] * p->n;
        p->n = 1;
        p->mono = 1;
        p->dispersed = 1;
    } else if (bs.pdf_is_estimate) {
        for (int j = 0; j < p->n; j++)
            p->beta[j] *= bs.pdf[j] > 0.0 ? bs.f[j] * cos_i / bs.pdf[j] : 0.0;
    } else {
        for (int j = 0; j < p->n; j++)
            p->beta[j] *= bs.f[j] * cos_i / pdf;
    }
    /* The emission this direction finds is weighed against light sampling with the pdf that
     * next-event estimation uses: for the coated models bsdf_pdf's estimate (pbrt-v4 does the
     * same when its sample's pdf is only proportional). */
    double mis_pdf = pdf;
    if (bs.pdf_is_estimate && !specular && c->bsdf_mis) {
        double pdfs[LANES];
        walk_position(c, VD_DIRECTION);
        bsdf_pdf(b, wo, bs.wi, &c->rng, pdfs);
        mis_pdf = pdfs[0];
    }
    /* Conductors and dielectrics, rough or smooth, polarise by their microfacets' Fresnel
     * matrices; diffuse, thin and layered models depolarise (docs/physics.md §14: a
     * simplification; a smooth coat's specular lobe sampled here is depolarised too). */
    if (p->polar)
        polar_bsdf(p, b, &fr, wo, bs.wi, wi);
    start_bounce(p, sf, wi, specular, specular ? 0.0 : mis_pdf);
    p->prev_n = fr.z;
    if (!specular) {
        p->diffuse_bounces++;
        p->surface_bounces++;
    }
    /* A receiver that gathered photons starts the chain, like a diffuse vertex: light that
     * reaches it through smooth mirrors and glass only came from the store. A specular sample
     * (a smooth coat's mirror lobe, which the BSDF evaluation and so the gather leave out)
     * and every surface that did not gather break it: light through them is path traced. */
    p->specular_since_diffuse = gathers && !specular ? 0 : CHAIN_BROKEN;
    if (sampled)
        *sampled = bs.flags;
    return 0;
}

/* pbrt-v4's subsurface material under "path" and "simplepath" (render/subsurface.h): its
 * dielectric boundary scatters as any bsdf/ model; light it refracts inside leaves at a point
 * a BSSRDF probe finds, weighted by the profile, and scatters there by the exit lobe (next-event
 * estimation and a cosine-sampled continuation) in a vertex block of its own, whose mix, glass
 * and fan-out slots (unused at an exit) place the probe. Returns 1 when the path ends. */
enum {
    VD_PROBE_AXIS = VD_MIX,
    VD_PROBE_RADIUS = VD_REFLECT,
    VD_PROBE_PHI = VD_FAN_JITTER,
    VD_PROBE_LANE = VD_FAN_PICK,
};

static int scatter_subsurface(ctx_t *c, path_t *p, const surface_t *sf, const material_t *m,
                              int regularized)
{
    bsdf_t b;
    path_bsdf(p, sf, m, regularized, &b);
    int flags = 0;
    /* Photons stop at subsurface materials (photon.c): no gather here or at the exit. */
    if (scatter_with(c, p, sf, &b, 0, &flags))
        return 1;
    if (!(flags & BSDF_TRANSMISSION))
        return 0; /* the boundary reflected it */
    vertex_begin(c, p);
    double sel[LANES];
    const int mis = p->n > 1;
    if (mis && !lanes_select(p, sel))
        return 1;
    const int hero = mis ? lanes_pick(sel, p->n, draw1(c, VD_PROBE_LANE)) : 0;
    const double u[3] = {draw1(c, VD_PROBE_AXIS), draw1(c, VD_PROBE_RADIUS),
                         draw1(c, VD_PROBE_PHI)};
    subsurface_exit_t ex;
    const bool found = subsurface_find_exit(c->scene, m, sf, p->lambda, p->n, hero,
                                            mis ? sel : NULL, u, &c->rng, &ex);
    c->stats->rays += (uint64_t)ex.rays;
    if (!found)
        return 1;
    for (int j = 0; j < p->n; j++)
        p->beta[j] *= ex.weight[j];
    if (!(max_beta(p) > 0.0))
        return 1;
    bsdf_t exit;
    subsurface_exit_bsdf(m, p->n, BSDF_RADIANCE, &exit);
    /* pbrt-v4 takes the light's way out to be along the exit's shading normal. */
    p->dir = vec3_neg(ex.sf.ns);
    return scatter_with(c, p, &ex.sf, &exit, 0, NULL);
}

/* Russian roulette after a bounce (thesis eq. 2.32-2.33): from RR_DEPTH bounces on, the path
 * survives with probability min(1, max(RR_MIN, max beta)) and is divided by it. Returns 1
 * when the path ends. Sheets crossed are not counted as bounces here (they count toward
 * maxdepth): light behind two polarisers, whose beta is a quarter, was otherwise rouletted from
 * its first diffuse bounce on, at a fifth, and speckled. */
static int roulette(ctx_t *c, path_t *p)
{
    double mb = max_beta(p);
    if (!(mb > 0.0))
        return 1;
    if (p->depth - p->sheets >= RR_DEPTH && c->rs->integrator != INTEGRATOR_WHITTED) {
        /* fmin(1, fmax(RR_MIN, mb)) for the positive mb here, without libm calls; mb times
         * the path's roulette scale (1 but at dense stones: split_dense). */
        double q = mb * p->rr_scale;
        q = q > RR_MIN ? q : RR_MIN;
        if (q > 1.0)
            q = 1.0;
        if (q < 1.0) {
            if (draw1(c, VD_ROULETTE) >= q)
                return 1;
            for (int j = 0; j < p->n; j++)
                p->beta[j] /= q;
        }
    }
    return 0;
}

/* Equiangular sampling toward a light point combined by MIS with free flight
 * (render_settings_t.medium_sampling; docs/physics.md §12, "Equiangular sampling"). Both
 * estimate the single-scattered light of one camera path segment of a homogeneous medium,
 *
 *     I = ∫_0^tmax ∫ T(t) sigma_s p(wo, w(x_t, y)) L_e(y) G(x_t, y) T(x_t, y) w_dir dA(y) dt,
 *
 * w_dir the power heuristic of next-event estimation against phase sampling at x_t (a
 * function of x_t and y, so the same integrand whichever technique samples it):
 *   A (free flight): t from the flight's scattering density q_s(t) (volume_scatter_pdf), y
 *     from next-event estimation at x_t: p_A(t, y) = q_s(t) P(y | x_t);
 *   B (equiangular): y from lights_sample at the segment's origin r, then t from the
 *     equiangular density toward y (sampling/equiangular.h): p_B(t, y) = P(y | r) pe(t | y).
 * P is the light sampler's density of the point in the area measure (lights_pdf's solid-angle
 * density times |cos| / d^2; for point and spot lights their probability alone: the delta
 * cancels in the ratio). Each technique's sample is weighted by the power heuristic of the two
 * joint densities (Veach 1997 §9.2), which sum to one at every (t, y), so the pair is unbiased
 * for I; the rest of the path (the phase-sampled continuation, the photon gather) stays the
 * free flight's alone. B applies only where it can do better: point and spot lights, and small
 * area lights whose shapes are sampled by area (eq_light_ok; not spheres, sampled by their
 * cone); a grid medium has no closed form for q_s, so its segments keep free flight alone
 * (docs/physics.md §12). */
typedef struct eq_segment {
    vec3_t org, dir;
    double tmax;
    const volume_lanes_t *k;
    const double *beta; /* the lanes' throughputs before the flight: what shared it */
} eq_segment_t;

/* Which lights B samples toward: point and spot lights, and area lights sampled by area whose
 * area is at most (EQ_SMALL_LIGHT scene_radius)^2. The singularity equiangular sampling removes
 * is a small light's (1/d^2 down to its size); a large one's light free flight and next-event
 * estimation already sample well, and B's extra light sample and shadow ray then cost more than
 * they save (docs/accuracy.md, "Equiangular sampling in fog": Bitterli's 5 mm light, sqrt(area)
 * 0.003 of the scene's radius, 1.0 to 6 times the efficiency; cornell-box-volume's, 0.24 of it,
 * 0.8 times). A property of the light alone, so A's weights and B's sampling agree on it. */
#define EQ_SMALL_LIGHT 0.05

static int eq_light_ok(const scene_t *s, int light)
{
    const light_t *l = &s->lights[light];
    if (l->kind == LIGHT_POINT || l->kind == LIGHT_SPOT)
        return 1;
    if (l->kind != LIGHT_AREA || s->shapes[l->shape].kind == SHAPE_SPHERE)
        return 0;
    const double r = EQ_SMALL_LIGHT * s->scene_radius;
    return s->shapes[l->shape].area <= r * r;
}

/* Whether any light of the scene is one B samples toward: else no segment runs it. */
static int eq_any_light(const scene_t *s)
{
    for (size_t i = 0; i < s->nlights; i++)
        if (eq_light_ok(s, (int)i))
            return 1;
    return 0;
}

/* The light point of sample ls taken at x: the light's position or the sampled point. */
static vec3_t eq_light_point(const scene_t *s, const light_sample_t *ls)
{
    const light_t *l = &s->lights[ls->light];
    return l->kind == LIGHT_AREA ? ls->p_light : l->position;
}

/* A light sampler's density for point y (of light sample ls) seen from p, given its solid-angle
 * pdf there (lights_sample's or lights_pdf's): in the area measure, pdf |cos| / d^2; a delta
 * light's probability as it is. */
static double eq_area_density(const light_sample_t *ls, double pdf, vec3_t p, vec3_t y)
{
    if (ls->is_delta)
        return pdf;
    const vec3_t d = vec3_sub(y, p);
    const double d2 = vec3_dot(d, d);
    if (!(d2 > 0.0) || !(d2 < INFINITY))
        return 0.0;
    return pdf * fabs(vec3_dot(ls->n_light, d)) / (d2 * sqrt(d2));
}

/* P(y | at): the density with which lights_sample at point `at` (in a medium) picks point y
 * of light sample ls (area measure; a delta light's probability), 0 where it cannot. *sa, when
 * asked, gets the solid-angle pdf (next-event estimation's own number). */
static double eq_light_density(const ctx_t *c, vec3_t at_p, const light_sample_t *ls, vec3_t y,
                               double *sa)
{
    const lights_at_t at = light_site(c, at_p, vec3_make(0.0, 0.0, 0.0));
    if (!eq_light_ok(c->scene, ls->light))
        return 0.0;
    double pdf;
    if (ls->is_delta) {
        pdf = lights_pmf(c->scene, &at, ls->light, 0);
    } else {
        const vec3_t d = vec3_sub(y, at_p);
        const double len = vec3_length(d);
        if (!(len > 0.0) || !(len < INFINITY))
            return 0.0;
        pdf = lights_pdf(c->scene, &at, ls->light, ls->tri, vec3_scale(d, 1.0 / len), y, ls->n_light);
    }
    if (sa)
        *sa = pdf;
    return eq_area_density(ls, pdf, at_p, y);
}

/* p_B(t, y) / P(y | r) for segment sg: the equiangular density of t toward y (0 where the
 * segment cannot be sampled toward y). */
static double eq_pdf(const eq_segment_t *sg, vec3_t y, double t)
{
    equiangular_t e;
    return equiangular_make(sg->org, sg->dir, sg->tmax, y, &e) ? equiangular_pdf(&e, t) : 0.0;
}

/* Next-event estimation at a scattering point x in medium m (phase function HG with the
 * medium's g): the light's emission times the phase function times the shadow ray's
 * transmittance, MIS-weighted against phase sampling by the power heuristic on the two
 * directional densities (either estimator is unbiased for the transmittance, so weights of
 * the direction alone sum to one). With sg (equiangular sampling on for the segment x lies on,
 * at distance t) also weighted as technique A of the pair above. */
static void direct_light_medium(ctx_t *c, const path_t *p, vec3_t x, double g,
                                const eq_segment_t *sg, double t)
{
    double u[4];
    light_uniforms(c, u);
    light_sample_t ls;
    const lights_at_t at = light_site(c, x, vec3_make(0.0, 0.0, 0.0));
    if (!lights_sample(c->scene, &at, u, &ls) || !(ls.pdf > 0.0))
        return;
    vec3_t dir;
    double tmax, tr[LANES];
    if (!shadow_segment(x, x, &ls, &dir, &tmax) || !shadow_ray(c, p, x, dir, tmax, p->medium, tr))
        return;
    const double ph = phase_hg_eval(vec3_neg(p->dir), ls.wi, g);
    double w = ls.is_delta ? 1.0 : power_heuristic(ls.pdf, ph);
    if (sg && eq_light_ok(c->scene, ls.light)) {
        const vec3_t y = eq_light_point(c->scene, &ls);
        /* next-event estimation's own pdf at x: lights_pdf's number to the last bit */
        const double pa = volume_scatter_pdf(sg->k, sg->beta, t) * eq_area_density(&ls, ls.pdf, x, y);
        const double pb = eq_light_density(c, sg->org, &ls, y, NULL) * eq_pdf(sg, y, t);
        w *= power_heuristic(pa, pb);
    }
    for (int j = 0; j < p->n; j++) {
        if (!(tr[j] > 0.0))
            continue;
        double le = lights_sample_emission_of(c->scene, &ls,
                                              light_value_lane(c, ls.light, j, p->lambda[j]),
                                              p->lambda[j]);
        splat(c, p, j, w * ph * le * tr[j] / ls.pdf);
    }
}

/* Technique B of the pair above for segment sg of the path p (its throughputs before the
 * flight), in a homogeneous medium of coefficients sg->k and phase g: a light point y from the
 * segment's origin, a distance from the equiangular density toward it, next-event estimation
 * at that point toward y, weighted against A. Its numbers come from the walk stream (c->rng):
 * a vertex block's dimensions are all spoken for, and free flight alone draws none of these. */
static void equiangular_scatter(ctx_t *c, const path_t *p, const eq_segment_t *sg, double g)
{
    double u[4];
    for (int i = 0; i < 4; i++)
        u[i] = rng_stream_next(&c->rng);
    const double ut = rng_stream_next(&c->rng);
    light_sample_t ls;
    const lights_at_t at_r = light_site(c, sg->org, vec3_make(0.0, 0.0, 0.0));
    if (!lights_sample(c->scene, &at_r, u, &ls) || !(ls.pdf > 0.0) || !eq_light_ok(c->scene, ls.light))
        return;
    const vec3_t y = eq_light_point(c->scene, &ls);
    const double pr = eq_area_density(&ls, ls.pdf, sg->org, y);
    equiangular_t e;
    if (!(pr > 0.0) || !equiangular_make(sg->org, sg->dir, sg->tmax, y, &e))
        return;
    const double t = equiangular_sample(&e, ut);
    const double pe = equiangular_pdf(&e, t);
    const vec3_t x = vec3_fma(sg->org, sg->dir, t);
    /* The sample as next-event estimation at x would see it. y on the ray (x = y) has no
     * direction: a measure-zero event, left out (shadow_segment refuses the empty segment). */
    const vec3_t d = vec3_sub(y, x);
    const double dist = vec3_length(d);
    if (!(pe > 0.0) || !(dist > 0.0) || !(dist < INFINITY))
        return;
    ls.wi = vec3_scale(d, 1.0 / dist);
    ls.dist = dist;
    double sa = 0.0;
    const double px = eq_light_density(c, x, &ls, y, &sa);
    const double qs = volume_scatter_pdf(sg->k, sg->beta, t);
    const double pb = pr * pe;
    const double w = power_heuristic(pb, qs * px);
    const double ph = phase_hg_eval(vec3_neg(sg->dir), ls.wi, g);
    /* Solid-angle pdf for the direction's MIS against phase sampling, as direct_light_medium
     * weights it (a light that next-event estimation at x cannot pick gives phase sampling all
     * of it: weight 0 here, as the integrand's w_dir says). */
    const double w_dir = ls.is_delta ? 1.0 : power_heuristic(sa, ph);
    /* G / P(y | r): cos_y / dist^2 over the area density; a delta light's 1 / dist^2 is in its
     * emission (lights_sample_emission_of), over its probability. */
    const double geo = ls.is_delta ? 1.0 / pr : fabs(vec3_dot(ls.n_light, ls.wi)) / (dist * dist) / pr;
    if (!(w * w_dir * ph * geo > 0.0))
        return;
    vec3_t dir;
    double tmax, tr[LANES];
    if (!shadow_segment(x, x, &ls, &dir, &tmax) || !shadow_ray(c, p, x, dir, tmax, p->medium, tr))
        return;
    const volume_lanes_t *k = sg->k;
    for (int j = 0; j < p->n; j++) {
        if (!(tr[j] > 0.0))
            continue;
        const double st = k->sigma_a[j] + k->sigma_s[j];
        const double T = st > 0.0 ? exp(-st * t) : 1.0;
        double le = lights_sample_emission_of(c->scene, &ls,
                                              light_value_lane(c, ls.light, j, p->lambda[j]),
                                              p->lambda[j]);
        splat(c, p, j, w * w_dir * k->sigma_s[j] * T * ph * le * geo * tr[j] / pe);
    }
}

/* The volume caustic at a scattering point x of the path (every one, as caustic_light at every
 * diffuse vertex), in a medium of phase g: the in-scattered radiance of the light paths
 * L S+ V that the photon pass stored (render/photon_volume.h), per lane the bucket its light
 * goes to. medium_flight then marks the chain (CHAIN_VOLUME), so the area light that the path
 * reaches from x through mindepth or more smooth surfaces is not counted again
 * (docs/physics.md §12). */
static void volume_caustic(ctx_t *c, const path_t *p, vec3_t x, double g)
{
    int bk[LANES];
    double L[LANES];
    for (int j = 0; j < p->n; j++)
        bk[j] = p->bucket[j] >= 0 ? p->bucket[j] : spectral_table_index(c->table, p->lambda[j]);
    if (!photon_volume_radiance(c->photons, x, vec3_neg(p->dir), g, p->n, bk, L))
        return;
    for (int j = 0; j < p->n; j++)
        if (L[j] > 0.0)
            splat(c, p, j, L[j]);
}

enum { FLIGHT_ENDS, FLIGHT_PASSED, FLIGHT_SCATTERED };

/* The path's free flight through its medium up to the next surface at tmax (volume.h): the
 * medium's emission is splatted, the lanes weighted, and a scattering event is a bounce (NEE,
 * then a direction from the phase function, whose weight p / pdf is 1), counted in depth and
 * followed by the roulette as surface bounces are (pbrt-v4 VolPathIntegrator). */
static int medium_flight(ctx_t *c, path_t *p, double tmax)
{
    const medium_t *m = c->scene->media[p->medium];
    volume_lanes_t k;
    volume_lanes_make(m, p->lambda, p->n, &k);
    /* Equiangular sampling's pair (eq_segment_t) where it applies: the vertex a scattering here
     * makes gets next-event estimation (below the maxdepth, not under simplepath). */
    const int eq = c->eq_lights &&
                   medium_kind(m) == MEDIUM_HOMOGENEOUS && p->depth < c->rs->maxdepth &&
                   c->rs->integrator != INTEGRATOR_SIMPLEPATH;
    double beta0[LANES];
    eq_segment_t sg = {p->org, p->dir, tmax, &k, beta0};
    if (eq) {
        memcpy(beta0, p->beta, (size_t)p->n * sizeof beta0[0]);
        equiangular_scatter(c, p, &sg, medium_g(m));
    }
    volume_flight_t f;
    volume_sample(m, &k, p->org, p->dir, tmax, p->beta, &c->rng, &f);
    if (k.emissive && p->depth < c->rs->maxdepth)
        for (int j = 0; j < p->n; j++)
            splat(c, p, j, f.emitted[j]);
    if (f.event == VOLUME_ABSORBED)
        return FLIGHT_ENDS;
    for (int j = 0; j < p->n; j++)
        p->beta[j] *= f.weight[j];
    if (f.event == VOLUME_PASSED)
        return max_beta(p) > 0.0 ? FLIGHT_PASSED : FLIGHT_ENDS;
    if (p->depth >= c->rs->maxdepth)
        return FLIGHT_ENDS;
    const vec3_t x = vec3_fma(p->org, p->dir, f.t);
    const double g = medium_g(m);
    if (c->rs->integrator != INTEGRATOR_SIMPLEPATH)
        direct_light_medium(c, p, x, g, eq ? &sg : NULL, f.t);
    const int gathers = c->photons && photon_store_has_volume(c->photons);
    if (gathers)
        volume_caustic(c, p, x, g);
    double ud[2], pdf;
    draw2(c, VD_DIRECTION, ud);
    vec3_t wi = phase_hg_sample(vec3_neg(p->dir), g, ud[0], ud[1], &pdf);
    if (p->polar)
        polar_carrier_depolarise(p->polar_t, p->n, &p->polar_x, vec3_neg(wi));
    p->prev_p = x;
    p->prev_n = vec3_make(0, 0, 0);
    p->org = x;
    p->dir = wi;
    p->specular = 0;
    p->bsdf_pdf = pdf;
    p->diffuse_bounces++;
    p->specular_since_diffuse = gathers ? CHAIN_VOLUME : CHAIN_BROKEN;
    p->depth++;
    return roulette(c, p) ? FLIGHT_ENDS : FLIGHT_SCATTERED;
}

/* A polariser or retarder sheet crossed straight (render/sheet.h). Without polarisation a
 * polariser passes half of the (unpolarised) light and a retarder all; with it the carrier
 * takes the element's normalised matrix (docs/physics.md §14). */
static void cross_sheet(path_t *p, const surface_t *sf, const material_t *m)
{
    const int polariser = m->kind == MATERIAL_POLARISER;
    if (polariser)
        for (int j = 0; j < p->n; j++)
            p->beta[j] *= 0.5;
    if (!p->polar)
        return;
    const vec3_t axis = sheet_axis(sf, m);
    const polar_event_t ev = polar_event_sheet(vec3_neg(p->dir), axis);
    mueller_t mm[LANES];
    const int per_lane = sheet_mueller(sf, m, axis, vec3_neg(p->dir), p->n, p->lambda, mm);
    if (!per_lane)
        mm[0] = mueller_normalised(&mm[0]);
    polar_carrier_apply(p->polar_t, p->n, &p->polar_x, &ev, mm, per_lane);
}

/* Small lamps seen directly (docs/rendering.md, "Small lamps seen directly"): the emission of
 * a probe lamp (lights_probes_t) that the camera ray itself finds, before any vertex, is a
 * sample's whole light on veach-mis's smallest sphere, and the only noise left there is where
 * in the pixel the sample fell (the direct lanes made its colour exact). So each camera
 * sample estimates that term from LAMP_PROBES positions: its own, at weight 1 / LAMP_PROBES,
 * and LAMP_PROBES - 1 more (sampler_pixel_extra) whose rays look only for those lamps: a ray
 * that may hit one (lights_probes_may_hit) is intersected with the scene, and its emission
 * added at the same weight times its filter weight over the sample's when the first surface
 * it meets is a probe lamp. Every position is uniform on its own, so the average is unbiased;
 * under "halton" a pixel's positions together are a (0,2)-net of LAMP_PROBES times the spp.
 * The term is the camera ray's own: its first intersection, no pass-through surface before,
 * no medium, a camera whose rays carry weight 1. */
#define LAMP_PROBES 4

static double probe_share(const ctx_t *c, const path_t *p, int light)
{
    return c->probe_pixel && p->vertex == 1 && p->passthrough == 0 &&
                   lights_probes_has(&c->probes, light)
               ? 1.0 / LAMP_PROBES
               : 1.0;
}

/* Whether pixel (fx, fy)'s camera rays may meet a probe lamp: for a pinhole perspective camera
 * every ray of the pixel's filter support lies in the cone about its centre's ray that holds the
 * support's corner rays (the image plane maps convex sets to convex cones of directions); other
 * cameras probe every pixel. A pure function of the pixel, so the estimate stays unbiased. */
static int probe_pixel(const ctx_t *c, const camera_frame_t *f, int fx, int fy)
{
    const camera_t *cam = &c->scene->camera;
    if (cam->kind != CAMERA_PERSPECTIVE || cam->lens_radius > 0.0)
        return 1;
    double rx = 0.5, ry = 0.5;
    if (c->scene->filter) {
        const filter_params_t *fp = filter_sampler_params(c->scene->filter);
        rx = fp->xradius;
        ry = fp->yradius;
    }
    vec3_t org, axis, d;
    camera_frame_ray(f, fx + 0.5, fy + 0.5, 0.5, 0.5, &org, &axis);
    double cos_min = 1.0;
    for (int k = 0; k < 4; k++) {
        camera_frame_ray(f, fx + 0.5 + (k & 1 ? rx : -rx), fy + 0.5 + (k & 2 ? ry : -ry), 0.5, 0.5,
                         &org, &d);
        cos_min = fmin(cos_min, vec3_dot(d, axis));
    }
    return lights_probes_in_cone(&c->probes, org, axis, acos(fmax(-1.0, fmin(1.0, cos_min))));
}

/* The probes of a camera sample whose path started as `start` (its lanes and throughput) with
 * film position u0 and filter weight w0. */
static void probe_lamps(ctx_t *c, const path_t *start, const camera_frame_t *f, int fx, int fy,
                        const double u0[2], double w0, const double lens[2])
{
    const scene_t *s = c->scene;
    for (uint32_t k = 1; k < LAMP_PROBES; k++) {
        double u[2];
        sampler_pixel_extra(&c->smp, k, LAMP_PROBES, u0, u);
        double weight = 1.0, px = fx + u[0], py = fy + u[1];
        if (s->filter) {
            filter_sample_t fs = filter_sampler_sample(s->filter, u[0], u[1]);
            px = fx + 0.5 + fs.dx;
            py = fy + 0.5 + fs.dy;
            weight = fs.weight;
        }
        vec3_t org, dir;
        camera_frame_ray(f, px, py, lens[0], lens[1], &org, &dir);
        if (!lights_probes_may_hit(&c->probes, org, dir))
            continue;
        hit_t h;
        c->stats->rays++;
        if (!geometry_intersect(s->geometry, org, dir, 0.0, INFINITY, &h))
            continue;
        surface_t sf;
        scene_surface(s, &h, &sf);
        if (sf.light < 0 || !lights_probes_has(&c->probes, sf.light))
            continue;
        path_t q;
        path_copy(&q, start);
        q.org = org;
        q.dir = dir;
        q.specular = 1;
        q.prev_p = org;
        q.vertex = 1;
        add_emission_hit(c, &q, &sf, &s->lights[sf.light], sf.light, h.prim,
                         weight / (w0 * LAMP_PROBES));
    }
}

/* Traces one path (and, via the stack, its branches) and splats what it finds. */
static void trace(ctx_t *c, path_t *start)
{
    const scene_t *s = c->scene;
    const int maxdepth = c->rs->maxdepth;
    c->top = 0;
    c->branches = 0;
    /* The camera path first, then the branches it pushed, last pushed first. */
    path_t cur;
    path_copy(&cur, start);
    for (;;) {
        path_t *p = &cur;
        for (;;) {
            hit_t h;
            c->stats->rays++;
            vertex_begin(c, p);
            const int hit = geometry_intersect(s->geometry, p->org, p->dir, 0.0, INFINITY, &h);
            if (c->media && p->medium >= 0) {
                int fl = medium_flight(c, p, hit ? h.t : INFINITY);
                if (fl == FLIGHT_ENDS)
                    break;
                if (fl == FLIGHT_SCATTERED)
                    continue;
            }
            if (!hit) {
                add_environment(c, p);
                break;
            }
            surface_t sf;
            scene_surface(s, &h, &sf);
            if (sf.shape->alpha && shading_alpha_pass(&sf, p->org, p->dir)) {
                if (++p->passthrough > MAX_PASSTHROUGH)
                    break;
                p->org = geometry_offset(sf.p, sf.ng, p->dir);
                continue;
            }
            /* With a caustic store, light that left an area light and reached a diffuse
             * vertex of the path (or its first glossy one) through mindepth or more specular
             * surfaces only (L S+ D S* E) comes from the photons gathered there: the path that
             * finds it the other way is not counted again. */
            if (sf.light >= 0 && s->lights[sf.light].kind == LIGHT_AREA &&
                !(c->photons &&
                  (p->specular_since_diffuse >= CHAIN_VOLUME
                       ? p->specular_since_diffuse - CHAIN_VOLUME >= c->mindepth
                       : p->surface_bounces >= 1 && p->specular_since_diffuse >= c->mindepth)))
                add_emission_hit(c, p, &sf, &s->lights[sf.light], sf.light, h.prim,
                                 probe_share(c, p, sf.light));
            const material_t *m = sf.material;
            if (m->kind == MATERIAL_MIX)
                m = shading_resolve(s, m, &sf, draw1(c, VD_MIX));
            if (m->kind == MATERIAL_INTERFACE) {
                if (++p->passthrough > MAX_PASSTHROUGH)
                    break;
                p->org = geometry_offset(sf.p, sf.ng, p->dir);
                p->medium = scene_medium_after(&sf, p->dir, p->medium);
                continue;
            }
            shading_perturb(m, &sf);
            if (p->depth >= maxdepth)
                break;
            vec3_t wo = vec3_neg(p->dir);
            /* pbrt-v4's anyNonSpecularBounces; a smooth surface becomes a rough bsdf/ lobe. */
            const int regularized = c->rs->regularize && !c->photons && p->diffuse_bounces > 0;
            if (m->kind == MATERIAL_DIFFUSE) {
                /* Lambertian with the shading normal n: cosine sampling around it and the
                 * cosine in light sampling. A direction below the geometric surface g (both
                 * on the viewer's side) would pass through the mesh: it contributes nothing
                 * and a sampled one ends the path, so no light leaks (a little energy is
                 * lost where shading and geometric normals differ, as in pbrt-v3's BSDF::f). */
                vec3_t g = vec3_dot(sf.ng, wo) >= 0.0 ? sf.ng : vec3_neg(sf.ng);
                vec3_t n = vec3_dot(sf.ns, g) >= 0.0 ? sf.ns : vec3_neg(sf.ns);
                double albedo[LANES];
                if (m->reflectance)
                    shading_texture_lanes(m->reflectance, &sf, p->lambda, p->n, albedo);
                else
                    for (int j = 0; j < p->n; j++)
                        albedo[j] = 0.5;
                if (c->rs->integrator != INTEGRATOR_SIMPLEPATH)
                    direct_light(c, p, &sf, n, g, albedo);
                if (c->photons)
                    caustic_light(c, p, &h, &sf, g, albedo);
                if (c->rs->integrator == INTEGRATOR_WHITTED)
                    break;
                double ud[2];
                draw2(c, VD_DIRECTION, ud);
                vec3_t local = sample_cosine_hemisphere(ud[0], ud[1]);
                vec3_t wi = sample_local_to_world(local, n);
                double cos_i = vec3_dot(wi, n);
                if (!(cos_i > 0.0) || !(vec3_dot(wi, g) > 0.0))
                    break;
                for (int j = 0; j < p->n; j++)
                    p->beta[j] *= albedo[j];
                if (p->polar)
                    polar_carrier_depolarise(p->polar_t, p->n, &p->polar_x, vec3_neg(wi));
                start_bounce(p, &sf, wi, 0, cos_i / PF_PI);
                p->prev_n = n;
                p->diffuse_bounces++;
                p->surface_bounces++;
                p->specular_since_diffuse = 0;
            } else if (material_is_sheet(m->kind)) {
                cross_sheet(p, &sf, m);
                start_bounce(p, &sf, p->dir, 1, 0.0);
                p->sheets++;
                /* With polarisation photons cross sheets as a specular event (photon.c), so
                 * the chain counts them; without, photons end there and light through a sheet
                 * is path traced. */
                if (p->polar)
                    p->specular_since_diffuse++;
                else
                    p->specular_since_diffuse = CHAIN_BROKEN;
            } else if (material_subsurface_table(m) && c->rs->integrator != INTEGRATOR_WHITTED) {
                if (scatter_subsurface(c, p, &sf, m, regularized))
                    break;
            } else if (!shading_is_delta(m, &sf) || (regularized && !material_uniaxial_of(m))) {
                /* regularize roughens smooth glass and metal, films included, not crystals
                 * (whose two waves no rough model carries): docs/compatibility.md,
                 * "Regularize". */
                if (scatter_bsdf(c, p, &sf, m, regularized))
                    break;
            } else if (m->kind == MATERIAL_CONDUCTOR) {
                const delta_conductor_t e =
                    delta_conductor_make(p->dir, specular_normal(&sf, p->dir, 0.0, NULL));
                const delta_film_t film = {m->film_thickness, &m->film_ior};
                mueller_t mm[LANES];
                for (int j = 0; j < p->n; j++) {
                    double eta, k;
                    shading_conductor_index(m, &sf, p->lambda[j], &eta, &k);
                    p->beta[j] *= m->film_thickness > 0.0
                                      ? delta_conductor_coated_weight(&e, eta, k, p->lambda[j], &film)
                                      : delta_conductor_weight(&e, eta, k);
                    if (p->polar)
                        mm[j] = delta_conductor_mueller(&e, eta, k, p->lambda[j],
                                                        m->film_thickness > 0.0 ? &film : NULL);
                }
                if (p->polar) {
                    const polar_event_t ev =
                        polar_event_interface(vec3_neg(e.reflect), vec3_neg(p->dir),
                                              specular_normal(&sf, p->dir, 0.0, NULL), p->polar_x);
                    polar_carrier_apply(p->polar_t, p->n, &p->polar_x, &ev, mm, 1);
                }
                start_bounce(p, &sf, e.reflect, 1, 0.0);
                p->specular_since_diffuse++;
            } else {
                /* Counted before the event, so that the branches it pushes carry it too. */
                p->specular_since_diffuse++;
                if (material_uniaxial_of(m) ? scatter_crystal(c, p, &sf, m, crystal_axis(s, &h, m))
                                : scatter_dielectric(c, p, &sf, m))
                    break;
            }
            p->depth++;
            if (roulette(c, p))
                break;
        }
        if (c->top == 0)
            break;
        path_copy(&cur, &c->stack[--c->top]);
    }
}

/* pbrt-v4 RGBFilm::AddSample: the sample's sensor record (c->xyz: XYZ for cie1931, a camera's
 * RGB) times the imaging ratio (exposuretime * iso / 100), scaled down so that its largest
 * component is at most maxcomponentvalue, then times the filter weight, then taken to XYZ by
 * the sensor's matrix (pbrt-v4 applies it to the pixel's mean; it is linear). Nothing changes
 * (not a bit) for cie1931 without white balance when all three are 1 and there is no clamp. */
static void sensor_weight(const render_settings_t *rs, const sensor_t *sensor, double weight,
                          double *contrib, int nb, double xyz[3])
{
    double k = rs->imaging_ratio;
    double m = fmax(xyz[0], fmax(xyz[1], xyz[2])) * k;
    if (m > rs->max_component)
        k *= rs->max_component / m;
    k *= weight;
    if (k != 1.0) {
        for (int b = 0; b < nb; b++)
            contrib[b] *= k;
        for (int i = 0; i < 3; i++)
            xyz[i] *= k;
    }
    if (sensor) {
        xyz_t t = sensor_to_xyz(sensor, (xyz_t){xyz[0], xyz[1], xyz[2]});
        xyz[0] = t.x;
        xyz[1] = t.y;
        xyz[2] = t.z;
    }
}

/* The camera ray for path p, whose lanes are set. A realistic camera with dispersive glass
 * refracts each wavelength its own way, so only one lane can follow the ray, as at a
 * dispersive smooth interface (docs/physics.md §4.5): with hero wavelengths the secondaries
 * are terminated and the hero weighted by the lane count; with fan-out one lane, picked
 * uniformly, goes on weighted by the count (its wavelength keeps its bucket's uniform density,
 * so it is not marked dispersed). The lens's weight multiplies every lane; 0: vignetted. */
static double lens_ray(ctx_t *c, path_t *p, const camera_frame_t *f, double px, double py, double u1, double u2)
{
    const camera_t *cam = &c->scene->camera;
    if (cam->kind == CAMERA_REALISTIC && cam->lens_dispersive && p->n > 1) {
        if (c->rs->dispersion == DISPERSION_FANOUT) {
            int k = (int)fmin(p->n - 1, floor(sampler_1d(&c->smp, DIM_LENS_LANE) * p->n));
            p->lambda[0] = p->lambda[k];
            p->bucket[0] = p->bucket[k];
            p->pdf[0] = p->pdf[k];
            p->beta[0] = p->beta[k] * p->n;
        } else {
            p->beta[0] *= p->n;
            p->dispersed = 1;
        }
        p->n = 1;
        p->mono = 1;
    }
    double w = camera_frame_ray_lambda(f, px, py, u1, u2, p->lambda[0], &p->org, &p->dir);
    p->specular = 1;
    p->medium = c->scene->camera_medium;
    p->prev_p = p->org;
    if (w != 1.0)
        for (int j = 0; j < p->n; j++)
            p->beta[j] *= w;
    return w;
}

/* The walk stream's seed (ctx_t.rng): apart from the sampler's own Philox numbers. */
#define WALK_SEED_MIX 0x6A09E667F3BCC908ull

int render_tile(const scene_t *scene, const photon_store_t *photons, int x0, int y0, int w, int h,
                uint32_t sample_begin, uint32_t sample_end, tilebuf_t *out, render_stats_t *stats,
                err_t *err)
{
    const render_settings_t *rs = &scene->settings;
    const int nb = rs->grid.n;
    const int nplanes = render_settings_buckets(rs);
    if (tilebuf_nbuckets(out) != nplanes)
        return err_set(err, "tile buffer has %d buckets, the film %d", tilebuf_nbuckets(out),
                       nplanes);
    if (rs->stokes && !rs->polarised)
        return err_set(err, "a Stokes output needs polarised transport");
    if (rs->dispersion == DISPERSION_FANOUT && nb > LANES)
        return err_set(err, "fan-out dispersion supports at most %d buckets, the film has %d", LANES, nb);
    if (x0 < 0 || y0 < 0 || x0 + w > rs->xres || y0 + h > rs->yres)
        return err_set(err, "tile %dx%d at (%d,%d) lies outside the %dx%d image", w, h, x0, y0,
                       rs->xres, rs->yres);
    if (rs->photon.enabled && (!photons || !photon_store_finished(photons)))
        return err_set(err, "the photon integrator's camera pass needs the finished store of its "
                            "photon pass");
    render_stats_t local = {0};
    if (!stats)
        stats = &local;
    double *contrib = malloc((size_t)nplanes * sizeof *contrib);
    path_t *stack = malloc(STACK_MAX * sizeof *stack);
    spectral_table_t *table = spectral_table_new(rs->grid, err);
    if (!contrib || !stack || !table) {
        free(contrib);
        free(stack);
        if (!table)
            return -1;
        spectral_table_destroy(&table);
        return err_set(err, "out of memory");
    }
    ctx_t c = {.scene = scene, .sensor = scene->sensor, .rs = rs, .contrib = contrib,
               .table = table, .stats = stats, .stack = stack,
               .fan_min = rs->grid.lambda_min, .fan_max = rs->grid.lambda_max,
               .fan_width = (rs->grid.lambda_max - rs->grid.lambda_min) / nb,
               .max_branches = WHITTED_BRANCHES_PER_BOUNCE * rs->maxdepth *
                               (rs->dispersion == DISPERSION_FANOUT ? nb : WAVELENGTH_HERO_COUNT)};
    for (int i = 0; i <= LE_CACHE_LIGHTS; i++)
        for (int j = 0; j < LANES; j++)
            c.le_cache[i][j].lambda = NAN;
    c.media = rs->media && scene->nmedia > 0;
    c.eq_lights = c.media && rs->medium_sampling == MEDIUM_SAMPLING_EQUIANGULAR && eq_any_light(scene);
    lights_probes_make(scene, &c.probes);
    /* Not with polarised transport: a probe ray's Stokes frame would be its own. */
    c.probing = c.probes.n > 0 && !c.media && !rs->polarised &&
                scene->camera.kind != CAMERA_REALISTIC && scene->camera_medium < 0;
    for (size_t i = 0; i < scene->nlights && rs->integrator == INTEGRATOR_PATH; i++)
        if (scene->lights[i].kind == LIGHT_AREA || scene->lights[i].kind == LIGHT_COLLIMATED ||
            scene->lights[i].kind == LIGHT_INFINITE)
            c.bsdf_mis = 1;
    /* Polarised transport: every camera ray starts with the analyser's matrix (or the
     * identity) in the frame x = the image's right, y = k x x (k toward the camera); for a
     * camera whose k x right is the image's down (frame_sign -1) the analyser's angle, given
     * from right toward up, is mirrored into that frame. */
    c.stokes = rs->stokes;
    vec3_t cam_right = vec3_make(1, 0, 0);
    mueller_t polar_start = mueller_identity();
    c.frame_sign = 1.0;
    if (rs->polarised) {
        const transform_t *cw = &scene->camera.camera_to_world;
        cam_right = vec3_normalize(transform_vector(cw, vec3_make(1, 0, 0)));
        const vec3_t up = transform_vector(cw, vec3_make(0, 1, 0));
        const vec3_t k = vec3_neg(transform_vector(cw, vec3_make(0, 0, 1)));
        c.frame_sign = vec3_dot(vec3_cross(k, cam_right), up) >= 0.0 ? 1.0 : -1.0;
        if (scene->camera.analyser)
            polar_start = mueller_polariser(c.frame_sign * scene->camera.analyser_angle);
    }
    double *irradiance = NULL;
    if (rs->photon.enabled) {
        c.photons = photons;
        c.glossy_photons = photon_store_directional(photons);
        irradiance = malloc((size_t)nb * sizeof *irradiance);
        if (!irradiance) {
            err_set(err, "out of memory");
            free(irradiance);
            free(contrib);
            free(stack);
            spectral_table_destroy(&table);
            return -1;
        }
        c.irradiance = irradiance;
        c.mindepth = rs->photon.mindepth;
    }
    /* A cropped film (scene.h) renders pixel (x, y) as pixel (x, y) + crop of the full film:
     * the camera and the random numbers see the full film. */
    const int full_w = rs->full_xres > 0 ? rs->full_xres : rs->xres;
    const int full_h = rs->full_yres > 0 ? rs->full_yres : rs->yres;
    const camera_frame_t frame = camera_frame_make(&scene->camera, full_w, full_h);
    const sampler_setup_t setup =
        sampler_setup_make(rs->sampler, rs->seed, (uint32_t)rs->spp, full_w, full_h);
    for (int y = y0; y < y0 + h; y++) {
        for (int x = x0; x < x0 + w; x++) {
            const int fx = x + rs->crop_x0, fy = y + rs->crop_y0;
            uint64_t pixel = (uint64_t)fy * (uint64_t)full_w + (uint64_t)fx;
            c.probe_pixel = c.probing && probe_pixel(&c, &frame, fx, fy);
            for (uint32_t s = sample_begin; s < sample_end; s++) {
                c.smp = sampler_start(&setup, fx, fy, full_w, s);
                sampler_use_cache(&c.smp, &c.smp_cache);
                c.rng = rng_stream_make(rs->seed ^ WALK_SEED_MIX, pixel, s);
                memset(contrib, 0, (size_t)nplanes * sizeof *contrib);
                c.xyz[0] = c.xyz[1] = c.xyz[2] = 0.0;
                path_t p;
                memset(&p, 0, offsetof(path_t, lambda));
                p.rr_scale = 1.0;
                /* The camera's block of dimensions (DIM_FILM...): the position in the
                 * pixel, the wavelengths, the lens. */
                double film[2], lens[2];
                sampler_2d(&c.smp, DIM_FILM, film);
                const double ul = sampler_1d(&c.smp, DIM_WAVELENGTH);
                c.wavelength_u = ul;
                sampler_2d(&c.smp, DIM_LENS, lens);
                const double jx = film[0], jy = film[1];
                /* Filter importance sampling (pbrt-v4 GetCameraSample): the stratified (jx, jy)
                 * mapped through the filter's inverse CDF gives the offset from the pixel
                 * centre and a weight (1, or -+ for mitchell's and sinc's negative lobes) the
                 * sample carries into its own pixel. Without a filter: the box of radius 1/2. */
                double weight = 1.0, px = fx + jx, py = fy + jy;
                if (scene->filter) {
                    filter_sample_t fs = filter_sampler_sample(scene->filter, jx, jy);
                    px = fx + 0.5 + fs.dx;
                    py = fy + 0.5 + fs.dy;
                    weight = fs.weight;
                }
                if (rs->dispersion == DISPERSION_FANOUT) {
                    /* Lane i at a wavelength uniform over bucket i, one jitter ul for all
                     * lanes (the sampler's wavelength dimension, as the hero's), so that its
                     * light's XYZ at that wavelength is unbiased (fanout_inverse_density). */
                    p.n = nb;
                    for (int i = 0; i < nb; i++) {
                        p.lambda[i] = rs->grid.lambda_min + ((double)i + ul) * c.fan_width;
                        p.beta[i] = 1.0;
                        p.pdf[i] = 1.0;
                        p.bucket[i] = i;
                    }
                } else {
                    wavelength_hero_t hw =
                        rs->visible_sampling
                            ? wavelength_hero_visible(ul)
                            : wavelength_hero_uniform(ul, rs->grid.lambda_min, rs->grid.lambda_max);
                    p.n = WAVELENGTH_HERO_COUNT;
                    for (int j = 0; j < p.n; j++) {
                        p.lambda[j] = hw.lambda[j];
                        p.pdf[j] = hw.pdf[j];
                        p.beta[j] = hw.pdf[j] > 0.0 ? 1.0 : 0.0;
                        p.bucket[j] = -1;
                    }
                }
                /* The camera ray after the wavelengths: the realistic camera's depends on them. */
                if (lens_ray(&c, &p, &frame, px, py, lens[0], lens[1]) > 0.0) {
                    if (rs->polarised) {
                        p.polar = 1;
                        p.polar_x = polar_frame_perp(cam_right, vec3_neg(p.dir));
                        for (int j = 0; j < p.n; j++)
                            p.polar_t[j] = polar_start;
                    }
                    trace(&c, &p);
                    if (c.probe_pixel)
                        probe_lamps(&c, &p, &frame, fx, fy, film, weight, lens);
                }
                sensor_weight(rs, c.sensor, weight, contrib, nplanes, c.xyz);
                if (tilebuf_add_sample(out, x, y, contrib, c.xyz))
                    stats->nonfinite++;
                stats->samples++;
            }
        }
    }
    free(irradiance);
    free(contrib);
    free(stack);
    spectral_table_destroy(&table);
    return 0;
}
