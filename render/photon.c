#include "photon.h"

#include "crystal_scatter.h"
#include "delta.h"
#include "lights.h"
#include "material_subsurface.h"
#include "phase_hg.h"
#include "photon_polar.h"
#include "photon_volume.h"
#include "rng.h"
#include "sample.h"
#include "sampler.h"
#include "shading.h"
#include "specular.h"
#include "volume.h"
#include "wavelength.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Photon i draws its numbers from (seed ^ PHOTON_SEED_MIX, i, 0, dim): without the mix,
 * photon i and pixel i's sample 0 would share every random number. */
#define PHOTON_SEED_MIX 0x50484F544F4E5321ull /* "PHOTONS!" */
/* Pass-through surfaces ("interface") are not bounces; this bounds them anyway. */
#define MAX_PASSTHROUGH 64

photon_job_t photon_job_from_settings(const render_settings_t *rs)
{
    return (photon_job_t){.seed = rs->seed,
                          .maxdepth = rs->photon.maxdepth,
                          .mindepth = rs->photon.mindepth,
                          .threshold = rs->photon.threshold,
                          .monochromerays = rs->photon.monochromerays,
                          .visible = rs->visible_sampling,
                          .policy = PHOTON_STORE_CAUSTIC};
}


typedef struct tracer {
    const scene_t *scene;
    const photon_job_t *job;
    alias_t *lights; /* the scene's power distribution without infinite lights */
    /* Caustic store: a sphere around every mirror and glass surface. A photon whose first hit
     * is diffuse is never stored, so photons are aimed at this sphere only (a bounding-sphere
     * version of Jensen's projection maps, Jensen 2001 sec. 6.2.2); aim_ok is 0 when a light
     * lies inside it, then that light emits everywhere. no_target: no specular surface at all,
     * so only a collimated light's photons can be stored (the others are not emitted). */
    int aim, no_target;
    vec3_t aim_centre;
    double aim_radius;
    photon_store_t *out;
    photon_stats_t *stats;
    rng_stream_t rng;
    /* The photon's wavelength (dimension 0) and its first PHOTON_LD_DIMS - 1 numbers (the
     * light, the point and direction of its emission, its first choices) come from one
     * scrambled Halton sequence over the photon index (sampler_index_1d), so that N photons
     * cover wavelengths, lights, positions and directions evenly and jointly; ld_dim counts
     * them, and ld_index is the photon (UINT64_MAX: Philox only, as for the lanes of a split,
     * whose numbers continue a path that is no longer the photon's). The wavelength is a
     * dimension of the same sequence, not a sequence of its own: two low-discrepancy
     * sequences over one index correlate (a golden-ratio lattice for the wavelength against
     * Halton survival draws left one bucket of a furnace 9 % short). */
    uint64_t ld_index;
    uint32_t ld_dim;
    /* The scene's media are simulated: photons fly through them and the store keeps volume
     * photons (photon_store_has_volume); light_medium[l] is the medium of a light with a fixed
     * position (point, spot, goniometric, projection; -2: found per photon). */
    int media;
    int *light_medium;
    /* Photons start white (photon_store_deposit_white) when the store takes them and nothing
     * makes a lane's path its own: one lane, no polarisation, no simulated media. */
    int white;
} tracer_t;

#define PHOTON_LD_DIMS 12
#define PHOTON_DIM_WAVELENGTH 0

static double next(tracer_t *t)
{
    if (t->ld_index != UINT64_MAX && t->ld_dim < PHOTON_LD_DIMS)
        return sampler_index_1d(t->job->seed ^ PHOTON_SEED_MIX, t->ld_index, t->ld_dim++);
    return rng_stream_next(&t->rng);
}

/* Samples a direction toward the aim sphere from o: uniform in the cone that the sphere
 * subtends. Returns the cone's solid angle 2 pi (1 - cos theta_max) (the inverse pdf), or 0
 * when o is inside the sphere (no cone). */
static double aim_cone(tracer_t *t, vec3_t o, vec3_t *dir)
{
    vec3_t d = vec3_sub(t->aim_centre, o);
    double d2 = vec3_dot(d, d), r2 = t->aim_radius * t->aim_radius;
    if (!(d2 > r2 * (1.0 + 1e-9)))
        return 0.0;
    double sin2 = r2 / d2;
    double cos_max = sqrt(1.0 - sin2);
    double u0 = next(t), u1 = next(t);
    *dir =
        sample_local_to_world(sample_uniform_cone(u0, u1, cos_max), vec3_scale(d, 1.0 / sqrt(d2)));
    /* 1 - cos_max without cancellation for small cones. */
    return 2.0 * PF_PI * sin2 / (1.0 + cos_max);
}

/* Where a photon of light l starts, in which direction, and the factor G by which the
 * light's spectral value (radiance, intensity or irradiance, l->scale * spectrum(lambda))
 * becomes the spectral power Phi(lambda) = value * G (W/nm) that its sampling densities of
 * position and direction turn into; G does not depend on the wavelength, so the lanes of a
 * photon share one emission:
 *   diffuse area light, radiance L: a uniform point (pdf 1/A) and a cosine direction
 *     (pdf cos/pi) give L cos / (cos/pi / A) = L pi A, twice that when two-sided (the side
 *     is picked with probability 1/2); aimed, a uniform direction in the cone omega of the
 *     aim sphere gives L cos A omega (0 below the surface);
 *   collimated area light (its L is the beam's irradiance): uniform point, direction the
 *     normal: L A;
 *   point light, intensity I: uniform direction, 4 pi I; aimed, I omega;
 *   spot light: uniform direction in the outer cone, I falloff(theta) 2 pi (1 - cos_max);
 *     aimed, I falloff(theta) omega;
 *   distant light, irradiance E: parallel rays through a disk perpendicular to the direction
 *     (the bounding sphere's, radius R, or the aim sphere's), started upstream of the whole
 *     scene: E pi R^2;
 *   goniometric and projection lights, intensity I f(w) with f the image's factor along w
 *     (lights_image_value of *texel, which depends on the wavelength, so the caller multiplies
 *     it in per lane): a direction drawn by the image's own density p(w) (envmap.h,
 *     projmap.h) gives I f / p; aimed, I f omega.
 * *texel is PHOTON_NO_TEXEL for lights without an image; an area light with an image sets
 * *area_uv to the point's texture coordinates (its radiance there is L lights_area_image, per
 * lane too) and leaves *texel so.
 * Returns 0 when the light emits no photon (infinite lights, degenerate shapes, a direction
 * outside a projection's frustum or of zero density). */
#define PHOTON_NO_TEXEL SIZE_MAX
static int emit(tracer_t *t, const light_t *l, vec3_t *org, vec3_t *dir, double *geom, size_t *texel,
                double area_uv[2])
{
    const scene_t *s = t->scene;
    double omega;
    *texel = PHOTON_NO_TEXEL;
    switch (l->kind) {
    case LIGHT_AREA:
    case LIGHT_COLLIMATED: {
        const shape_t *sh = &s->shapes[l->shape];
        double u0 = next(t), u1 = next(t), u2 = next(t);
        vec3_t p, n;
        if (!lights_sample_shape(sh, u0, u1, u2, &p, &n, l->area_image ? area_uv : NULL))
            return 0;
        if (l->kind == LIGHT_COLLIMATED) {
            *dir = n;
            *geom = sh->area;
        } else {
            double side = 1.0;
            if (l->twosided && next(t) < 0.5)
                n = vec3_neg(n);
            if (l->twosided)
                side = 2.0;
            if (t->aim && (omega = aim_cone(t, p, dir)) > 0.0) {
                double cos_e = vec3_dot(*dir, n);
                if (!(cos_e > 0.0))
                    return 0;
                *geom = cos_e * sh->area * side * omega;
            } else {
                double u3 = next(t), u4 = next(t);
                *dir = sample_local_to_world(sample_cosine_hemisphere(u3, u4), n);
                *geom = PF_PI * sh->area * side;
            }
        }
        *org = geometry_offset(p, n, *dir);
        return 1;
    }
    case LIGHT_POINT:
        *org = l->position;
        if (t->aim && (omega = aim_cone(t, l->position, dir)) > 0.0) {
            *geom = omega;
        } else {
            double u0 = next(t), u1 = next(t);
            *dir = sample_uniform_sphere(u0, u1);
            *geom = 4.0 * PF_PI;
        }
        return 1;
    case LIGHT_SPOT: {
        double cmax = l->cos_total_width;
        *org = l->position;
        if (t->aim && (omega = aim_cone(t, l->position, dir)) > 0.0) {
            *geom = lights_spot_falloff(l, vec3_dot(*dir, l->direction)) * omega;
            return 1;
        }
        if (!(cmax < 1.0))
            return 0;
        double u0 = next(t), u1 = next(t);
        vec3_t local = sample_uniform_cone(u0, u1, cmax);
        *dir = sample_local_to_world(local, l->direction);
        *geom = lights_spot_falloff(l, local.z) * 2.0 * PF_PI * (1.0 - cmax);
        return 1;
    }
    case LIGHT_GONIOMETRIC:
    case LIGHT_PROJECTION: {
        *org = l->position;
        if (t->aim && (omega = aim_cone(t, l->position, dir)) > 0.0) {
            *geom = omega;
        } else {
            double u0 = next(t), u1 = next(t), pdf;
            vec3_t wl = l->kind == LIGHT_GONIOMETRIC ? envmap_sample(l->gonio, u0, u1, texel, &pdf)
                                                     : projmap_sample(l->projmap, u0, u1, texel, &pdf);
            if (!(pdf > 0.0) || !isfinite(pdf))
                return 0;
            *dir = vec3_normalize(transform_vector(&l->from_light, wl));
            *geom = 1.0 / pdf;
            return 1;
        }
        *texel = lights_image_texel(l, *dir);
        return *texel != PROJMAP_OUTSIDE;
    }
    case LIGHT_DISTANT: {
        double u0 = next(t), u1 = next(t);
        vec3_t scene_centre = vec3_scale(vec3_add(s->bounds_lo, s->bounds_hi), 0.5);
        vec3_t centre = t->aim ? t->aim_centre : scene_centre;
        double R = t->aim ? t->aim_radius : s->scene_radius;
        vec3_t a, b;
        vec3_basis(l->direction, &a, &b);
        vec3_t q = sample_concentric_disk(u0, u1);
        vec3_t p = vec3_add(centre, vec3_add(vec3_scale(a, R * q.x), vec3_scale(b, R * q.y)));
        /* Back along the direction until upstream of the scene's bounding sphere, so that
         * the photon crosses everything that could shade the aimed disk. */
        double back = vec3_dot(vec3_sub(p, scene_centre), l->direction) + 1.05 * s->scene_radius;
        *org = vec3_fma(p, l->direction, -back);
        *dir = l->direction;
        *geom = PF_PI * R * R;
        return 1;
    }
    case LIGHT_INFINITE:
        return 0;
    }
    return 0;
}

/* Grows the box lo..hi by the world-space corners of the box blo..bhi under to_world. */
static void grow_box(vec3_t *lo, vec3_t *hi, const transform_t *to_world, vec3_t blo, vec3_t bhi)
{
    for (int c = 0; c < 8; c++) {
        vec3_t q = vec3_make(c & 1 ? bhi.x : blo.x, c & 2 ? bhi.y : blo.y, c & 4 ? bhi.z : blo.z);
        vec3_t w = to_world ? transform_point(to_world, q) : q;
        *lo = vec3_make(fmin(lo->x, w.x), fmin(lo->y, w.y), fmin(lo->z, w.z));
        *hi = vec3_make(fmax(hi->x, w.x), fmax(hi->y, w.y), fmax(hi->z, w.z));
    }
}

/* The box of one shape in its own space (world space for world meshes). */
static void shape_box(const shape_t *sh, vec3_t *lo, vec3_t *hi, transform_t *to_space,
                      int *has_transform)
{
    *lo = vec3_make(INFINITY, INFINITY, INFINITY);
    *hi = vec3_make(-INFINITY, -INFINITY, -INFINITY);
    *has_transform = sh->kind != SHAPE_MESH;
    if (sh->kind == SHAPE_MESH) {
        for (size_t v = 0; v < sh->nverts; v++) {
            vec3_t q =
                vec3_make(sh->positions[3 * v], sh->positions[3 * v + 1], sh->positions[3 * v + 2]);
            grow_box(lo, hi, NULL, q, q);
        }
    } else {
        double r = sh->radius;
        double zlo = sh->kind == SHAPE_SPHERE ? -r : sh->height,
               zhi = sh->kind == SHAPE_SPHERE ? r : sh->height;
        *lo = vec3_make(-r, -r, zlo);
        *hi = vec3_make(r, r, zhi);
        *to_space = sh->to_world;
    }
}

/* The aim sphere: around the world-space boxes of every mirror and glass shape, and with
 * polarisation every sheet (photons cross them), instanced copies included. Returns 0 when
 * there is none. */
static int specular_sphere(const scene_t *s, vec3_t *centre, double *radius)
{
    vec3_t lo = vec3_make(INFINITY, INFINITY, INFINITY),
           hi = vec3_make(-INFINITY, -INFINITY, -INFINITY);
    int any = 0;
    for (size_t i = 0; i < s->nshapes; i++) {
        const shape_t *sh = &s->shapes[i];
        const material_t *m = &s->materials[sh->material];
        /* Aim at what the pass follows: smooth mirrors and glass (a roughness texture may be
         * smooth in places). */
        const int sheet = s->settings.polarised && material_is_sheet(m->kind);
        if (((m->kind != MATERIAL_DIELECTRIC && m->kind != MATERIAL_CONDUCTOR) || m->rough ||
             material_subsurface_table(m)) &&
            !sheet)
            continue;
        vec3_t blo, bhi;
        transform_t own;
        int has_own;
        shape_box(sh, &blo, &bhi, &own, &has_own);
        if (!(blo.x <= bhi.x))
            continue;
        if (has_own) {
            vec3_t wlo = vec3_make(INFINITY, INFINITY, INFINITY), whi = vec3_neg(wlo);
            grow_box(&wlo, &whi, &own, blo, bhi);
            blo = wlo;
            bhi = whi;
        }
        if (sh->object < 0) {
            grow_box(&lo, &hi, NULL, blo, bhi);
            any = 1;
            continue;
        }
        for (size_t k = 0; k < s->ninstances; k++)
            if (s->instances[k].object == sh->object) {
                grow_box(&lo, &hi, &s->instances[k].to_world, blo, bhi);
                any = 1;
            }
    }
    if (!any)
        return 0;
    *centre = vec3_scale(vec3_add(lo, hi), 0.5);
    double r = 0.5 * vec3_length(vec3_sub(hi, lo));
    /* A margin for rounding, and for flat shapes (a mirror disk) a radius above zero. */
    *radius = r * (1.0 + 1e-6) + 1e-9 * (1.0 + vec3_length(*centre));
    return 1;
}

/* The most monochrome rays a photon may follow (photon_job_t.monochromerays). */
#define MAX_LANES PHOTON_MAX_MONOCHROME_RAYS
_Static_assert(MAX_LANES <= PHOTON_POLAR_MAX_LANES, "a photon's lanes fit its polarisation");

/* A photon in flight: one geometric ray carrying nl wavelengths ("lanes") that have refracted
 * alike so far, each with its own raw power. */
typedef struct flight {
    vec3_t org, dir;
    int nl;
    double lambda[MAX_LANES];
    double w[MAX_LANES];  /* raw power now, W/nm */
    double w0[MAX_LANES]; /* raw power at emission, for the threshold */
    int depth, specular, diffuse, passthrough;
    int collimated;
    int wave; /* inside a uniaxial crystal: the wave (bsdf/uniaxial.h) */
    int medium; /* the medium it travels in (index into scene->media, -1: vacuum) when media
                 * are simulated */
    /* The lanes' polarisation (render_settings_t.polarised; photon_polar.h), NULL without:
     * then sheets end the photon and every interface acts on intensities. */
    photon_polar_t *pol;
    /* A white photon (docs/rendering.md, "White photons"): its path so far did not depend on
     * the wavelength, so it stands for every wavelength at once; w[0] and w0[0] are then its
     * power per unit of its light's spectrum (scale x spectrum(lambda) x w[0] is the power of
     * the coloured photon it would be at lambda, before the wavelength's pdf), lambda[0]
     * unused. light: its light's index. The first event that depends on the wavelength makes
     * it coloured (colour_flight). */
    int white, light;
} flight_t;

/* The total over the film's buckets of a white photon's power per unit spectrum (the stats'
 * power, as a coloured photon's sum). */
static double white_total(const tracer_t *t, int light)
{
    const double *c = photon_store_white_spectrum(t->out, PHOTON_MAP_WHITE(light));
    double s = 0.0;
    for (int b = 0; c && b < t->scene->settings.grid.n; b++)
        s += c[b];
    return s;
}

/* A white photon becomes the coloured photon of the wavelength it would have been emitted
 * with (dimension 0 of photon i's sequence, as trace_one draws it): power scale x
 * spectrum(lambda) / pdf(lambda) per unit of what it carries. Its path so far was the same at
 * every wavelength, so this is the coloured photon traced so far, and the estimate keeps its
 * expectation. */
static void colour_flight(tracer_t *t, flight_t *f, uint64_t i)
{
    if (!f->white)
        return;
    const spectral_grid_t grid = t->scene->settings.grid;
    const light_t *l = &t->scene->lights[f->light];
    const double u = sampler_index_1d(t->job->seed ^ PHOTON_SEED_MIX, i, PHOTON_DIM_WAVELENGTH);
    const wavelength_sample_t ws =
        t->job->visible ? wavelength_sample_visible(u)
                        : wavelength_sample_uniform(u, grid.lambda_min, grid.lambda_max);
    const double k = ws.pdf > 0.0 ? l->scale * spectrum_eval(l->spectrum, ws.lambda) / ws.pdf : 0.0;
    f->lambda[0] = ws.lambda;
    f->w[0] = isfinite(k) ? f->w[0] * k : 0.0;
    f->w0[0] = isfinite(k) ? f->w0[0] * k : 0.0;
    f->white = 0;
}

static int deposit_lanes(tracer_t *t, const flight_t *f, const hit_t *h, const surface_t *sf,
                         vec3_t g, err_t *err)
{
    photon_stats_t *st = t->stats;
    /* Counted and dropped rather than stored (docs/physics.md §6.4: no NaN or Inf in any
     * store); the store refuses them too. */
    if (!isfinite(sf->p.x) || !isfinite(sf->p.y) || !isfinite(sf->p.z)) {
        st->nonfinite++;
        return 0;
    }
    if (f->white) {
        if (!(f->w[0] <= FLT_MAX)) {
            st->nonfinite++;
            return 0;
        }
        if (!(f->w[0] > 0.0))
            return 0;
        if (photon_store_deposit_white(t->out, sf->p, f->dir, g, f->light, f->w[0], err))
            return -1;
        st->deposited++;
        st->power_deposited += f->w[0] * white_total(t, f->light);
        return 0;
    }
    for (int j = 0; j < f->nl; j++) {
        if (!(f->w[j] <= FLT_MAX)) {
            st->nonfinite++;
            continue;
        }
        if (!(f->w[j] > 0.0))
            continue;
        if (photon_store_deposit(t->out, h, sf->p, f->dir, g, f->lambda[j], f->w[j], err))
            return -1;
        st->deposited++;
        st->power_deposited += f->w[j];
    }
    return 0;
}

static int trace_flight(tracer_t *t, flight_t *f, uint64_t i, err_t *err);

enum { STEP_ENDS, STEP_PASSED, STEP_SCATTERED };

/* The photon's free flight through its medium up to the next surface at tmax, with volume.h's
 * sampling (the camera pass's: the lanes share one flight, each weighted by its own density
 * over the mixture; f->w chooses). A scattering event is where the caustic store keeps a
 * volume photon, by the rule of a surface's (after mindepth specular events and no diffuse
 * one, or straight from a collimated light), with power Phi / sigma_s(lambda, x)
 * (photon_store_deposit_volume); there the caustic store's photon ends, as at a diffuse
 * surface (the camera pass path traces what it scatters on), the full store's goes on in a
 * direction from the phase function (weight 1). Returns STEP_* or -1 when the store cannot
 * take a deposit. */
static int medium_step(tracer_t *t, flight_t *f, double tmax, err_t *err)
{
    const medium_t *m = t->scene->media[f->medium];
    const photon_job_t *job = t->job;
    photon_stats_t *st = t->stats;
    if (!m)
        return STEP_PASSED;
    volume_lanes_t k;
    volume_lanes_make(m, f->lambda, f->nl, &k);
    volume_flight_t fl;
    volume_sample(m, &k, f->org, f->dir, tmax, f->w, &t->rng, &fl);
    if (fl.event == VOLUME_ABSORBED) {
        st->culled++;
        return STEP_ENDS;
    }
    for (int j = 0; j < f->nl; j++)
        f->w[j] *= fl.weight[j];
    if (fl.event == VOLUME_PASSED)
        return STEP_PASSED;
    const vec3_t x = vec3_fma(f->org, f->dir, fl.t);
    const int store = job->policy == PHOTON_STORE_CAUSTIC
                          ? (f->specular >= job->mindepth || (f->collimated && !f->specular)) &&
                                !f->diffuse
                          : f->depth >= job->mindepth;
    if (store && isfinite(x.x) && isfinite(x.y) && isfinite(x.z)) {
        const double density = medium_density(m, x);
        for (int j = 0; j < f->nl; j++) {
            const double sigma_s = density * medium_coeffs(m, f->lambda[j]).sigma_s;
            const double power = sigma_s > 0.0 ? f->w[j] / sigma_s : 0.0;
            if (!(power <= FLT_MAX)) {
                st->nonfinite++;
                continue;
            }
            if (!(power > 0.0))
                continue;
            if (photon_store_deposit_volume(t->out, x, f->dir, f->lambda[j], power, err))
                return -1;
            st->deposited++;
            st->power_deposited += f->w[j];
        }
    }
    if (job->policy == PHOTON_STORE_CAUSTIC || f->depth >= job->maxdepth)
        return STEP_ENDS;
    double pdf;
    const double u0 = next(t), u1 = next(t);
    f->dir = phase_hg_sample(vec3_neg(f->dir), medium_g(m), u0, u1, &pdf);
    f->org = x;
    f->diffuse = 1;
    f->depth++;
    if (f->pol)
        photon_polar_depolarise(f->pol, f->dir, f->nl);
    return STEP_SCATTERED;
}

/* At a dispersive interface a photon of several lanes splits into one photon per lane (thesis
 * 5.5, following every monochrome ray); each continues with numbers of its own, keyed by
 * (photon, 2 + lane), so the result does not depend on the order they are traced in. */
static int split_flight(tracer_t *t, const flight_t *f, uint64_t i, err_t *err)
{
    photon_polar_t pol;
    for (int j = 0; j < f->nl; j++) {
        flight_t one = *f;
        one.nl = 1;
        one.lambda[0] = f->lambda[j];
        one.w[0] = f->w[j];
        one.w0[0] = f->w0[j];
        if (f->pol) {
            pol.x = f->pol->x;
            pol.s[0] = f->pol->s[j];
            one.pol = &pol;
        }
        t->rng = rng_stream_make(t->job->seed ^ PHOTON_SEED_MIX, i, 2 + (uint64_t)j);
        t->ld_index = UINT64_MAX;
        if (trace_flight(t, &one, i, err))
            return -1;
    }
    return 0;
}

/* Follows a photon until it is absorbed, escapes or is stored for good. Returns -1 only when
 * the store cannot take a deposit. */
static int trace_flight(tracer_t *t, flight_t *f, uint64_t i, err_t *err)
{
    const scene_t *s = t->scene;
    const photon_job_t *job = t->job;
    photon_stats_t *st = t->stats;
    for (;;) {
        hit_t h;
        st->rays++;
        const int hit = geometry_intersect(s->geometry, f->org, f->dir, 0.0, INFINITY, &h);
        if (t->media && f->medium >= 0) {
            const int fl = medium_step(t, f, hit ? h.t : INFINITY, err);
            if (fl < 0)
                return -1;
            if (fl == STEP_ENDS)
                return 0;
            if (fl == STEP_SCATTERED)
                continue;
        }
        if (!hit) {
            st->escaped++;
            return 0;
        }
        surface_t sf;
        scene_surface(s, &h, &sf);
        if (sf.shape->alpha && shading_alpha_pass(&sf, f->org, f->dir)) {
            if (++f->passthrough > MAX_PASSTHROUGH)
                return 0;
            f->org = geometry_offset(sf.p, sf.ng, f->dir);
            continue;
        }
        const material_t *m = sf.material;
        if (m->kind == MATERIAL_MIX)
            m = shading_resolve(s, m, &sf, next(t));
        if (m->kind == MATERIAL_INTERFACE) {
            if (++f->passthrough > MAX_PASSTHROUGH)
                return 0;
            f->org = geometry_offset(sf.p, sf.ng, f->dir);
            f->medium = scene_medium_after(&sf, f->dir, f->medium);
            continue;
        }
        /* Without polarisation a polariser or retarder sheet ends a photon, and the camera
         * pass path traces the light through it (render.c breaks its chain there); with it the
         * photon crosses, a specular event (below). */
        const int sheet = material_is_sheet(m->kind);
        if (sheet && !f->pol)
            return 0;
        /* Nor do they enter a subsurface material (render/subsurface.h): light beneath it is
         * diffused, and the camera pass path traces what leaves it. */
        if (material_subsurface_table(m))
            return 0;
        shading_perturb(m, &sf);
        if (m->kind == MATERIAL_DIFFUSE) {
            /* The side the photon arrived on decides the normal stored and the hemisphere it
             * leaves into: the geometric surface, so that no photon crosses a wall. */
            vec3_t g = vec3_dot(sf.ng, f->dir) < 0.0 ? sf.ng : vec3_neg(sf.ng);
            /* A collimated light is a delta in direction: no camera path or light sample ever
             * finds it, so its direct light (L D) goes into the caustic store as well. */
            int store = job->policy == PHOTON_STORE_CAUSTIC
                            ? (f->specular >= job->mindepth || (f->collimated && !f->specular)) &&
                                  !f->diffuse
                            : f->depth >= job->mindepth;
            if (store && deposit_lanes(t, f, &h, &sf, g, err))
                return -1;
            if (job->policy == PHOTON_STORE_CAUSTIC)
                return 0;
            if (f->depth >= job->maxdepth) {
                st->culled++;
                return 0;
            }
            /* Russian roulette on the albedo (thesis eq. 2.32): continue with probability
             * q = the largest lane albedo, each lane weighted by rho_j / q. */
            double rho[MAX_LANES], q = 0.0;
            for (int j = 0; j < f->nl; j++) {
                rho[j] = m->reflectance ? shading_texture(m->reflectance, &sf, f->lambda[j]) : 0.5;
                q = fmax(q, rho[j]);
            }
            q = fmin(1.0, q);
            if (!(next(t) < q))
                return 0;
            for (int j = 0; j < f->nl; j++)
                f->w[j] *= rho[j] / q;
            double u0 = next(t), u1 = next(t);
            f->dir = sample_local_to_world(sample_cosine_hemisphere(u0, u1), g);
            f->org = geometry_offset(sf.p, sf.ng, f->dir);
            f->medium = scene_medium_after(&sf, f->dir, f->medium);
            f->diffuse = 1;
            if (f->pol)
                photon_polar_depolarise(f->pol, f->dir, f->nl);
        } else if (!sheet && !shading_is_delta(m, &sf)) {
            /* A glossy receiver (any other non-delta surface: coated, rough conductor or
             * dielectric, diffuse transmission). A store that keeps directions (a photon map)
             * takes the caustic here as at a diffuse surface, L S+ G by the same rule, and the
             * camera pass evaluates the receiver's BSDF with each photon's direction
             * (render.c's caustic_light_bsdf); light maps cannot, so there the camera pass path
             * traces it (CHAIN_BROKEN). Either way the photon ends: what the surface scatters
             * on is path traced from the camera. */
            /* A thin dielectric's BSDF is all delta: the camera pass never gathers there. */
            if (job->policy == PHOTON_STORE_CAUSTIC && photon_store_directional(t->out) &&
                m->kind != MATERIAL_THIN_DIELECTRIC &&
                (f->specular >= job->mindepth || (f->collimated && !f->specular)) && !f->diffuse) {
                vec3_t g = vec3_dot(sf.ng, f->dir) < 0.0 ? sf.ng : vec3_neg(sf.ng);
                if (deposit_lanes(t, f, &h, &sf, g, err))
                    return -1;
            }
            return 0;
        } else {
            if (f->depth >= job->maxdepth) {
                st->culled++;
                return 0;
            }
            /* Mirrors, crystals and coated or dispersive glass treat each wavelength their
             * own way: a white photon takes its wavelength here. */
            if (m->kind == MATERIAL_CONDUCTOR || material_uniaxial_of(m) || m->dispersive ||
                m->film_thickness > 0.0 || sheet)
                colour_flight(t, f, i);
            if (sheet) {
                photon_polar_sheet(f->pol, &sf, m, f->dir, f->nl, f->lambda, f->w);
            } else if (m->kind == MATERIAL_CONDUCTOR && f->pol) {
                const vec3_t nrm = specular_normal(&sf, f->dir, 0.0, NULL);
                const delta_conductor_t e = delta_conductor_make(f->dir, nrm);
                double eta[MAX_LANES], k[MAX_LANES];
                for (int j = 0; j < f->nl; j++)
                    shading_conductor_index(m, &sf, f->lambda[j], &eta[j], &k[j]);
                photon_polar_conductor(f->pol, f->dir, e.reflect, nrm, eta, k, f->lambda,
                                       m->film_thickness, &m->film_ior, f->nl, f->w);
                f->dir = e.reflect;
            } else if (m->kind == MATERIAL_CONDUCTOR) {
                const delta_conductor_t e =
                    delta_conductor_make(f->dir, specular_normal(&sf, f->dir, 0.0, NULL));
                const delta_film_t film = {m->film_thickness, &m->film_ior};
                for (int j = 0; j < f->nl; j++) {
                    double eta, k;
                    shading_conductor_index(m, &sf, f->lambda[j], &eta, &k);
                    f->w[j] *= m->film_thickness > 0.0
                                   ? delta_conductor_coated_weight(&e, eta, k, f->lambda[j], &film)
                                   : delta_conductor_weight(&e, eta, k);
                }
                f->dir = e.reflect;
            } else if (material_uniaxial_of(m)) {
                /* A crystal splits every wavelength its own way (render/crystal_scatter.h). */
                if (f->nl > 1)
                    return split_flight(t, f, i, err);
                int end;
                crystal_polar_t cp = {.x = f->pol ? f->pol->x : f->dir,
                                      .s_in = f->pol ? &f->pol->s[0] : NULL};
                if (crystal_scatter(m, &sf, crystal_axis(s, &h, m), f->org, f->dir, &f->wave,
                                    f->nl, f->lambda, f->w, BSDF_IMPORTANCE, next(t), &f->dir,
                                    &end, f->pol ? &cp : NULL))
                    return 0;
                if (f->pol)
                    photon_polar_apply(f->pol, &cp.ev, &cp.m, 0, f->nl, f->w);
            } else {
                if (m->dispersive && f->nl > 1)
                    return split_flight(t, f, i, err);
                /* Smooth glass at the photon's wavelength (all lanes alike when the glass
                 * does not disperse), in importance mode (bsdf/delta.h): reflect with
                 * probability R, refract with 1 - R, and the flux keeps its power. */
                const bool entering = vec3_dot(f->dir, sf.ng) < 0.0;
                const double n = ior_eval(&m->ior, f->lambda[0]);
                vec3_t nrm = specular_normal(&sf, f->dir, delta_eta_ratio(n, entering), NULL);
                delta_dielectric_t e;
                if (f->pol) {
                    photon_polar_dielectric(f->pol, f->dir, nrm, entering, n, m->film_thickness,
                                            &m->film_ior, f->lambda, f->nl, next(t), f->w,
                                            &f->dir);
                } else if (m->film_thickness > 0.0) {
                    /* A coating: every lane its own reflectance (interference), the branch
                     * chosen with their mean, each lane weighed by its own over it. */
                    double ns[MAX_LANES];
                    for (int j = 0; j < f->nl; j++)
                        ns[j] = n;
                    delta_dielectric_make(f->dir, nrm, entering, ns, f->nl, BSDF_IMPORTANCE, &e);
                    const delta_film_t film = {m->film_thickness, &m->film_ior};
                    delta_dielectric_coat(&e, f->dir, nrm, entering, ns, f->lambda, &film);
                    const bool reflect = next(t) < e.prob_reflect;
                    const double scale = reflect ? 1.0 : 1.0 / (1.0 - e.prob_reflect);
                    for (int j = 0; j < f->nl; j++)
                        f->w[j] *= reflect ? delta_dielectric_reflect_lane(&e, j, true)
                                           : delta_dielectric_transmit_lane(&e, j, scale);
                    f->dir = reflect ? e.reflect : e.refract;
                } else {
                    delta_dielectric_make(f->dir, nrm, entering, &n, 1, BSDF_IMPORTANCE, &e);
                    bool reflect;
                    const double w = delta_dielectric_choose(&e, next(t), &reflect, &f->dir);
                    for (int j = 0; j < f->nl; j++)
                        f->w[j] *= w;
                }
            }
            f->org = geometry_offset(sf.p, sf.ng, f->dir);
            f->medium = scene_medium_after(&sf, f->dir, f->medium);
            f->specular++;
        }
        f->depth++;
        /* The power threshold (thesis 5.5) as Russian roulette, which keeps the estimate
         * unbiased: below threshold of its emitted power (the lanes' sum) the photon survives
         * with probability (fraction / threshold) and is scaled back up. */
        double sum = 0.0, sum0 = 0.0;
        for (int j = 0; j < f->nl; j++) {
            sum += f->w[j];
            sum0 += f->w0[j];
        }
        double frac = sum / sum0;
        if (!(frac > 0.0))
            return 0;
        if (frac < job->threshold) {
            double q = frac / job->threshold;
            if (next(t) >= q) {
                st->culled++;
                return 0;
            }
            for (int j = 0; j < f->nl; j++)
                f->w[j] /= q;
        }
    }
}

/* Traces photon i: job->monochromerays lanes at stratified wavelengths. Returns -1 only when
 * the store cannot take a deposit. */
static int trace_one(tracer_t *t, uint64_t i, err_t *err)
{
    const scene_t *s = t->scene;
    const photon_job_t *job = t->job;
    const spectral_grid_t grid = s->settings.grid;
    photon_stats_t *st = t->stats;
    t->rng = rng_stream_make(job->seed ^ PHOTON_SEED_MIX, i, 0);
    t->ld_index = i;
    t->ld_dim = PHOTON_DIM_WAVELENGTH + 1;
    double pmf;
    const light_t *l = &s->lights[alias_sample(t->lights, next(t), &pmf)];
    vec3_t org, dir;
    double geom;
    size_t texel;
    double area_uv[2] = {0.0, 0.0};
    if (!(pmf > 0.0) || !emit(t, l, &org, &dir, &geom, &texel, area_uv))
        return 0;
    /* Wavelengths: u_i, the sequence's base-2 dimension (an Owen-scrambled van der Corput
     * sequence: every aligned run of 2^k photons puts one in each interval of 2^-k), and for
     * M lanes its rotations by k / M (hero-wavelength style, Wilkie et al. 2014). Each lane is
     * uniform, so the estimate stays unbiased, and every bucket receives its share of any N
     * photons to within a few, which removes the colour noise of independent draws. */
    flight_t f = {.org = org, .dir = dir, .nl = job->monochromerays,
                  .collimated = l->kind == LIGHT_COLLIMATED, .medium = -1};
    if (t->media)
        f.medium = t->light_medium[l - s->lights] != -2 ? t->light_medium[l - s->lights]
                                                         : photon_volume_medium_at(s, org, dir);
    if (t->white && texel == PHOTON_NO_TEXEL && !l->area_image) {
        /* White: the power per unit of the light's spectrum; the wavelength waits until the
         * path depends on it (colour_flight). */
        const double w = geom / pmf;
        f.white = 1;
        f.light = (int)(l - s->lights);
        f.lambda[0] = 0.5 * (grid.lambda_min + grid.lambda_max);
        f.w[0] = f.w0[0] = isfinite(w) ? w : 0.0;
        if (!isfinite(w))
            st->nonfinite++;
        st->power_emitted += f.w[0] * white_total(t, f.light);
        if (!(f.w[0] > 0.0))
            return 0;
        return trace_flight(t, &f, i, err);
    }
    uint64_t ui =
        (uint64_t)(sampler_index_1d(job->seed ^ PHOTON_SEED_MIX, i, PHOTON_DIM_WAVELENGTH) *
                   0x1p64);
    int alive = 0;
    for (int j = 0; j < f.nl; j++) {
        uint64_t uj = ui + (uint64_t)((double)j / f.nl * 0x1p64 * (1.0 - 0x1p-53));
        double u = (double)(uj >> 11) * 0x1p-53;
        /* "wavelengths" "visible" samples by the eye's response (pbrt-v4's pdf, 360-830 nm);
         * a lane outside the film's range is lost like any photon that leaves the scene. */
        wavelength_sample_t ws = job->visible
                                     ? wavelength_sample_visible(u)
                                     : wavelength_sample_uniform(u, grid.lambda_min, grid.lambda_max);
        double img = texel != PHOTON_NO_TEXEL ? lights_image_value(l, texel, ws.lambda)
                     : l->area_image  ? lights_area_image(l, area_uv[0], area_uv[1], ws.lambda)
                                      : 1.0;
        double w = ws.pdf > 0.0
                       ? l->scale * spectrum_eval(l->spectrum, ws.lambda) * img * geom / (pmf * ws.pdf)
                       : 0.0;
        f.lambda[j] = ws.lambda;
        if (!isfinite(w)) {
            st->nonfinite++;
            w = 0.0;
        }
        st->power_emitted += w;
        f.w[j] = f.w0[j] = w;
        alive |= w > 0.0;
    }
    if (!alive)
        return 0;
    photon_polar_t pol;
    if (s->settings.polarised) {
        photon_polar_emit(&pol, l, f.dir, f.nl);
        f.pol = &pol;
    }
    return trace_flight(t, &f, i, err);
}

/* The share of light l's power that an aimed emission sends toward the aim sphere, roughly
 * (seen from the centre of an area light's shape), kept in [1e-3, 1] so that every light
 * that can reach a specular surface keeps a chance. */
static double aimed_share(const tracer_t *t, const light_t *l)
{
    const scene_t *s = t->scene;
    if (!t->aim)
        return 1.0;
    double f = 1.0;
    vec3_t from = l->position;
    switch (l->kind) {
    case LIGHT_COLLIMATED:
    case LIGHT_INFINITE:
        return 1.0;
    case LIGHT_DISTANT:
        f = t->aim_radius * t->aim_radius / (s->scene_radius * s->scene_radius);
        break;
    case LIGHT_AREA: {
        vec3_t lo, hi;
        transform_t own;
        int has_own;
        shape_box(&s->shapes[l->shape], &lo, &hi, &own, &has_own);
        from = vec3_scale(vec3_add(lo, hi), 0.5);
        if (has_own)
            from = transform_point(&own, from);
    }
        /* fall through */
    case LIGHT_POINT:
    case LIGHT_SPOT:
    case LIGHT_GONIOMETRIC:
    case LIGHT_PROJECTION: {
        vec3_t d = vec3_sub(t->aim_centre, from);
        double d2 = vec3_dot(d, d), r2 = t->aim_radius * t->aim_radius;
        if (!(d2 > r2))
            return 1.0;
        double sin2 = r2 / d2, omega = 2.0 * PF_PI * sin2 / (1.0 + sqrt(1.0 - sin2));
        /* A goniometric light counts as isotropic, a projection as filling its frustum. */
        f = l->kind == LIGHT_AREA         ? omega / PF_PI
            : l->kind == LIGHT_POINT || l->kind == LIGHT_GONIOMETRIC ? omega / (4.0 * PF_PI)
            : l->kind == LIGHT_PROJECTION ? omega / projmap_solid_angle(l->projmap)
                                          : omega / (2.0 * PF_PI * fmax(1e-9, 1.0 - l->cos_total_width));
        break;
    }
    }
    return fmin(1.0, fmax(1e-3, f));
}

/* Which light a photon comes from: in proportion to power (scene->light_power) and, when
 * photons are aimed, to the share of it that heads for the specular surfaces, so that a
 * narrow beam at a prism is not starved by a large room light of which only a sliver
 * reaches the glass. Any choice with every useful light's probability above zero is
 * unbiased, as each photon divides by it. Environment lights emit no photons. */
static alias_t *photon_lights(const tracer_t *t, err_t *err)
{
    const scene_t *s = t->scene;
    if (!s->light_power || s->nlights == 0) {
        err_set(err, "the photon pass needs a light: the scene has none");
        return NULL;
    }
    double *w = malloc(s->nlights * sizeof *w);
    if (!w) {
        err_set(err, "out of memory");
        return NULL;
    }
    double total = 0.0;
    int others = 0;
    for (size_t i = 0; i < s->nlights; i++) {
        const light_t *l = &s->lights[i];
        others |= l->kind != LIGHT_INFINITE;
        int useless = l->kind == LIGHT_INFINITE || (t->no_target && l->kind != LIGHT_COLLIMATED);
        total += w[i] = useless ? 0.0 : alias_pmf(s->light_power, i) * aimed_share(t, l);
    }
    alias_t *a = NULL;
    if (total > 0.0)
        a = alias_new(w, s->nlights, err);
    else if (!others)
        err_set(err, "the photon pass needs a light other than an environment: environment lights "
                     "emit no photons");
    else
        err_set(
            err,
            "no photon could be stored: the scene has no glass or mirror and no collimated light");
    free(w);
    return a;
}

int photon_trace(const scene_t *scene, const photon_job_t *job, uint64_t i0, uint64_t i1,
                 photon_store_t *out, photon_stats_t *stats, err_t *err)
{
    if (i1 < i0)
        return err_set(err, "photon range [%llu, %llu) is reversed", (unsigned long long)i0,
                       (unsigned long long)i1);
    if (job->maxdepth < 0 || !(job->threshold >= 0.0 && job->threshold < 1.0) ||
        job->mindepth < 0 || job->monochromerays < 1 || job->monochromerays > MAX_LANES)
        return err_set(err, "photon job: maxdepth %d, mindepth %d, threshold %g or monochromerays %d out of range",
                       job->maxdepth, job->mindepth, job->threshold, job->monochromerays);
    photon_stats_t local = {0};
    tracer_t t = {.scene = scene, .job = job, .out = out, .stats = &local};
    if (job->policy == PHOTON_STORE_CAUSTIC) {
        t.aim = specular_sphere(scene, &t.aim_centre, &t.aim_radius);
        t.no_target = !t.aim;
    }
    if (!(t.lights = photon_lights(&t, err))) {
        if (!t.no_target)
            return -1;
        t.no_target = 2; /* nothing to trace: every photon is emitted and lost */
    }
    t.media = photon_store_has_volume(out);
    t.white = job->policy == PHOTON_STORE_CAUSTIC && photon_store_white(out) && !t.media &&
              job->monochromerays == 1 && !scene->settings.polarised;
    if (t.media) {
        if (!(t.light_medium = malloc((scene->nlights ? scene->nlights : 1) * sizeof(int)))) {
            alias_destroy(&t.lights);
            return err_set(err, "out of memory");
        }
        for (size_t l = 0; l < scene->nlights; l++) {
            const light_t *li = &scene->lights[l];
            const int fixed = li->kind == LIGHT_POINT || li->kind == LIGHT_SPOT ||
                              li->kind == LIGHT_GONIOMETRIC || li->kind == LIGHT_PROJECTION;
            t.light_medium[l] =
                fixed ? photon_volume_medium_at(scene, li->position, li->direction) : -2;
        }
    }
    int r = 0;
    for (uint64_t i = i0; i < i1 && !r && t.no_target != 2; i++)
        r = trace_one(&t, i, err);
    alias_destroy(&t.lights);
    free(t.light_medium);
    if (r)
        return -1;
    /* Every lane is a monochrome photon of the estimate: the store divides by all of them. */
    local.emitted = (i1 - i0) * (uint64_t)job->monochromerays;
    photon_store_add_emitted(out, local.emitted);
    if (stats)
        photon_stats_add(stats, &local);
    return 0;
}

void photon_stats_add(photon_stats_t *sum, const photon_stats_t *s)
{
    sum->emitted += s->emitted;
    sum->deposited += s->deposited;
    sum->rays += s->rays;
    sum->escaped += s->escaped;
    sum->culled += s->culled;
    sum->nonfinite += s->nonfinite;
    sum->power_emitted += s->power_emitted;
    sum->power_deposited += s->power_deposited;
}
