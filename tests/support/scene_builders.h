/* scene_builders: the scenes the rendering and photon tests build through the scene API, and the
 * optics oracles that go with them (test_photon.c, test_photon_caustic.c,
 * test_lightmap_caustic.c): a scene for the camera pass and its camera, diffuse and glass
 * materials, a collimated beam, an equilateral N-BK7 prism at minimum deviation with its screen,
 * a glass ball focusing a disk light onto a floor, and the image statistics of a rendered tile;
 * and scenes loaded from pbrt-v4 text or a file. Every oracle here is computed from its formula
 * (SCHOTT Sellmeier coefficients written out), never taken from the renderer. Header-only (each
 * test is its own executable); include after cmocka.h. Names start with sb_ (scene builder). */
#ifndef PRISMFARM_SCENE_BUILDERS_H
#define PRISMFARM_SCENE_BUILDERS_H

#include "glass.h"
#include "pbrt_parser.h"
#include "photon_pass.h"
#include "render.h"
#include "scene.h"
#include "scene_load.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Scene pieces. */

/* A 4 x 4 quad in the x-y plane as pbrt-v4 scene text, for tests that build a scene from a
 * file: normal +z and u along +x (PBRT_QUAD), or the same quad wound to face -z
 * (PBRT_QUAD_BACK). */
#define PBRT_QUAD                                                                                  \
    "Shape \"trianglemesh\" \"point3 P\" [-2 -2 0  2 -2 0  2 2 0  -2 2 0] \"integer indices\" "    \
    "[0 1 2 0 2 3] \"point2 uv\" [0 0 1 0 1 1 0 1]\n"
#define PBRT_QUAD_BACK                                                                             \
    "Shape \"trianglemesh\" \"point3 P\" [-2 -2 0  2 -2 0  2 2 0  -2 2 0] \"integer indices\" "    \
    "[0 2 1 0 3 2] \"point2 uv\" [0 0 1 0 1 1 0 1]\n"

/* An empty scene with seed 7. */
static inline scene_t *sb_new_scene(void)
{
    err_t err;
    scene_t *s = scene_new(&err);
    if (!s)
        fail_msg("scene_new: %s", err.msg);
    s->settings.seed = 7;
    return s;
}

/* An empty scene for the camera-pass tests: the integrator and dispersion strategy, res x res
 * pixels at spp, maxdepth 64, wavelengths sampled uniformly (no visible-importance sampling),
 * scene_new's seed. */
static inline scene_t *sb_render_scene(integrator_kind_t integ, dispersion_kind_t disp, int res,
                                       int spp)
{
    err_t err;
    scene_t *s = scene_new(&err);
    assert_non_null(s);
    s->settings.integrator = integ;
    s->settings.dispersion = disp;
    s->settings.spp = spp;
    s->settings.maxdepth = 64;
    s->settings.xres = res;
    s->settings.yres = res;
    s->settings.visible_sampling = 0;
    return s;
}

/* The camera at eye looking at at (+y up) with a field of view of fov degrees. */
static inline void sb_look_at(scene_t *s, vec3_t eye, vec3_t at, double fov)
{
    transform_t cam;
    assert_int_equal(transform_look_at(eye, at, vec3_make(0, 1, 0), &cam, NULL), 0);
    s->camera.camera_to_world = transform_inverse(cam);
    s->camera.fov_deg = fov;
}

/* A constant spectrum owned by the scene. */
static inline const spectrum_t *sb_constant(scene_t *s, double v)
{
    err_t err;
    spectrum_t *sp = spectrum_new_constant(v, &err);
    assert_non_null(sp);
    assert_int_equal(scene_own_spectrum(s, sp, &err), 0);
    return sp;
}

/* A diffuse material of constant albedo; returns its index. */
static inline int sb_diffuse(scene_t *s, double albedo)
{
    err_t err;
    spectrum_t *sp = spectrum_new_constant(albedo, &err);
    assert_non_null(sp);
    texture_t *t = texture_new_constant(sp, &err); /* the texture owns sp */
    assert_non_null(t);
    assert_int_equal(scene_own_texture(s, t, &err), 0);
    material_t m = {.kind = MATERIAL_DIFFUSE, .reflectance = t};
    strcpy(m.name, "diffuse");
    int i = scene_add_material(s, &m, &err);
    assert_true(i >= 0);
    return i;
}

/* A material of the given kind, of the catalogue glass when glass is not NULL. */
static inline int sb_material(scene_t *s, material_kind_t kind, const char *glass)
{
    err_t err;
    material_t m = {.kind = kind};
    if (glass)
        m.ior = glass_find(glass)->ior;
    snprintf(m.name, sizeof m.name, "%s", glass ? glass : "m");
    int i = scene_add_material(s, &m, &err);
    assert_true(i >= 0);
    return i;
}

static inline void sb_finish(scene_t *s)
{
    err_t err;
    if (scene_finish(s, &err))
        fail_msg("scene_finish: %s", err.msg);
}

/* A collimated disk light of radius r at `at`, emitting along `dir`, with irradiance 1. */
static inline void sb_beam(scene_t *s, vec3_t at, vec3_t dir, double r)
{
    err_t err;
    light_t l = {.kind = LIGHT_COLLIMATED, .spectrum = sb_constant(s, 1.0), .scale = 1.0};
    int li = scene_add_light(s, &l, &err);
    assert_true(li >= 0);
    /* The disk's normal +z turned onto dir. */
    vec3_t z = vec3_normalize(dir), x, y;
    vec3_basis(z, &x, &y);
    double m[4][4] = {
        {x.x, y.x, z.x, at.x}, {x.y, y.y, z.y, at.y}, {x.z, y.z, z.z, at.z}, {0, 0, 0, 1}};
    transform_t t = transform_from_matrix(m);
    assert_true(
        scene_add_disk(s, &t, r, 0.0, sb_material(s, MATERIAL_INTERFACE, NULL), li, 0, &err) >= 0);
}

/* ------------------------------------------------------------------------------------------ */
/* Optics oracles. */

/* SCHOTT Sellmeier coefficients (SCHOTT optical glass data sheets 2017), lambda in um. */
static inline double sb_sellmeier(const double B[3], const double C[3], double lambda_nm)
{
    double l2 = lambda_nm * lambda_nm * 1e-6;
    return sqrt(1.0 + B[0] * l2 / (l2 - C[0]) + B[1] * l2 / (l2 - C[1]) + B[2] * l2 / (l2 - C[2]));
}
static const double SB_SF11_B[3] = {1.73759695, 0.313747346, 1.89878101};
static const double SB_SF11_C[3] = {0.013188707, 0.0623068142, 155.23629};
static const double SB_BK7_B[3] = {1.03961212, 0.231792344, 1.01046945};
static const double SB_BK7_C[3] = {0.00600069867, 0.0200179144, 103.560653};

/* Snell's law in vector form (Born & Wolf 1.5): d unit, n unit facing the incident side;
 * 0 on total internal reflection. */
static inline int sb_snell(vec3_t d, vec3_t n, double n1, double n2, vec3_t *t)
{
    double c = -vec3_dot(d, n), eta = n1 / n2, k = 1.0 - eta * eta * (1.0 - c * c);
    if (k < 0.0)
        return 0;
    *t = vec3_normalize(vec3_add(vec3_scale(d, eta), vec3_scale(n, eta * c - sqrt(k))));
    return 1;
}

/* Unpolarised Fresnel transmittance, cosine form (Born & Wolf 1.5.2). */
static inline double sb_fresnel_t(double cos_i, double n1, double n2)
{
    double sin_t = n1 / n2 * sqrt(fmax(0.0, 1.0 - cos_i * cos_i));
    if (sin_t >= 1.0)
        return 0.0;
    double cos_t = sqrt(1.0 - sin_t * sin_t);
    double rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    double rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    return 1.0 - 0.5 * (rs * rs + rp * rp);
}

/* Transmittance of a slab at normal incidence with every internal reflection summed
 * (incoherently): T = (1 - R)^2 / (1 - R^2) = (1 - R) / (1 + R) with R = ((n-1)/(n+1))^2,
 * which is 2n / (n^2 + 1). */
static inline double sb_slab_t(double n)
{
    return 2.0 * n / (n * n + 1.0);
}

/* ------------------------------------------------------------------------------------------ */
/* The prism: an equilateral N-BK7 prism (side 0.1, height 0.2, axis y) set at minimum deviation
 * for PRISM_LAMBDA0 (the centre of bucket 8 of the default grid) under a collimated beam along
 * +x of radius 0.5 mm through the middle of its first face, and a 0.6 x 0.6 diffuse screen
 * (albedo 0.8) PRISM_THROW away, perpendicular to the beam leaving at PRISM_LAMBDA0. */
#define PRISM_LAMBDA0 560.625
#define PRISM_APEX (PF_PI / 3.0)
#define PRISM_THROW 5.0

typedef struct sb_prism {
    vec3_t v[3];               /* the triangle in the y = 0 plane */
    vec3_t entry;              /* where the beam's axis meets the first face */
    vec3_t exit_dir0;          /* leaving direction at PRISM_LAMBDA0 */
    vec3_t exit0;              /* where it leaves at PRISM_LAMBDA0 */
    vec3_t screen_c, screen_e; /* screen centre and its horizontal axis */
    int screen;                /* the screen's shape index */
} sb_prism_t;

/* The outward unit normal of the prism's face (v[a] v[b]). */
static inline vec3_t sb_prism_outward(const sb_prism_t *p, int a, int b)
{
    vec3_t e = vec3_sub(p->v[b], p->v[a]);
    vec3_t n = vec3_normalize(vec3_make(e.z, 0, -e.x));
    vec3_t c = vec3_scale(vec3_add(vec3_add(p->v[0], p->v[1]), p->v[2]), 1.0 / 3.0);
    return vec3_dot(n, vec3_sub(p->v[a], c)) < 0 ? vec3_neg(n) : n;
}

/* The central ray at wavelength lambda: into face (v0 v1), out of face (v0 v2), onto the
 * screen plane; returns its coordinate along screen_e and (if deviation is not NULL) the
 * deviation angle. */
static inline double sb_prism_land(const sb_prism_t *p, double lambda, double *deviation)
{
    double n = sb_sellmeier(SB_BK7_B, SB_BK7_C, lambda);
    vec3_t d = vec3_make(1, 0, 0), t = d, o = d;
    assert_true(sb_snell(d, sb_prism_outward(p, 0, 1), 1.0, n, &t));
    vec3_t n2 = sb_prism_outward(p, 0, 2);
    double s = vec3_dot(vec3_sub(p->v[0], p->entry), n2) / vec3_dot(t, n2);
    vec3_t q = vec3_fma(p->entry, t, s);
    assert_true(sb_snell(t, vec3_neg(n2), n, 1.0, &o));
    if (deviation)
        *deviation = acos(fmin(1.0, vec3_dot(o, d)));
    vec3_t sn = p->exit_dir0;
    double u = vec3_dot(vec3_sub(p->screen_c, q), sn) / vec3_dot(o, sn);
    return vec3_dot(vec3_sub(vec3_fma(q, o, u), p->screen_c), p->screen_e);
}

/* Adds the beam, the prism and the screen to s (new, with its settings chosen), fills p,
 * finishes s and returns it. */
static inline scene_t *sb_prism_build(sb_prism_t *p, scene_t *s)
{
    /* In the prism's own frame the apex is up (+w), the base along u; at minimum deviation
     * the ray inside runs parallel to the base, so the beam meets the first face at
     * i0 = asin(n0 sin(A/2)) and travels at i0 - A/2 above the base. The frame is turned so
     * that the beam runs along +x. */
    double n0 = sb_sellmeier(SB_BK7_B, SB_BK7_C, PRISM_LAMBDA0);
    double i0 = asin(n0 * sin(PRISM_APEX / 2.0));
    double a = -(i0 - PRISM_APEX / 2.0), side = 0.1, h = side * sqrt(3.0) / 2.0;
    double uv[3][2] = {{0.0, h}, {-side / 2.0, 0.0}, {side / 2.0, 0.0}};
    for (int k = 0; k < 3; k++)
        p->v[k] = vec3_make(uv[k][0] * cos(a) - uv[k][1] * sin(a), 0.0,
                            uv[k][0] * sin(a) + uv[k][1] * cos(a));
    p->entry = vec3_scale(vec3_add(p->v[0], p->v[1]), 0.5);
    vec3_t t = vec3_make(1, 0, 0);
    assert_true(sb_snell(vec3_make(1, 0, 0), sb_prism_outward(p, 0, 1), 1.0, n0, &t));
    vec3_t n2 = sb_prism_outward(p, 0, 2);
    p->exit0 = vec3_fma(p->entry, t, vec3_dot(vec3_sub(p->v[0], p->entry), n2) / vec3_dot(t, n2));
    assert_true(sb_snell(t, vec3_neg(n2), n0, 1.0, &p->exit_dir0));
    p->screen_c = vec3_fma(p->exit0, p->exit_dir0, PRISM_THROW);
    p->screen_e = vec3_normalize(vec3_cross(vec3_make(0, 1, 0), p->exit_dir0));

    sb_beam(s, vec3_fma(p->entry, vec3_make(1, 0, 0), -0.2), vec3_make(1, 0, 0), 0.0005);
    double P[18];
    for (int k = 0; k < 6; k++) {
        vec3_t q = p->v[k % 3];
        P[3 * k] = q.x;
        P[3 * k + 1] = k < 3 ? -0.1 : 0.1;
        P[3 * k + 2] = q.z;
    }
    uint32_t tri[8][3] = {{0, 1, 2}, {3, 5, 4}, {0, 3, 4}, {0, 4, 1},
                          {1, 4, 5}, {1, 5, 2}, {2, 5, 3}, {2, 3, 0}};
    /* Orient every triangle outward (normal = (p0 - p2) x (p1 - p2), pbrt-v4's rule). */
    vec3_t c = vec3_make((p->v[0].x + p->v[1].x + p->v[2].x) / 3, 0,
                         (p->v[0].z + p->v[1].z + p->v[2].z) / 3);
    for (int k = 0; k < 8; k++) {
        vec3_t q[3];
        for (int j = 0; j < 3; j++)
            q[j] = vec3_make(P[3 * tri[k][j]], P[3 * tri[k][j] + 1], P[3 * tri[k][j] + 2]);
        vec3_t nrm = vec3_cross(vec3_sub(q[0], q[2]), vec3_sub(q[1], q[2]));
        vec3_t mid = vec3_scale(vec3_add(vec3_add(q[0], q[1]), q[2]), 1.0 / 3.0);
        if (vec3_dot(nrm, vec3_sub(mid, c)) < 0) {
            uint32_t x = tri[k][0];
            tri[k][0] = tri[k][1];
            tri[k][1] = x;
        }
    }
    assert_true(scene_add_mesh(s, P, 6, &tri[0][0], 8, NULL, NULL,
                               sb_material(s, MATERIAL_DIELECTRIC, "N-BK7"), -1, 0, NULL) >= 0);
    vec3_t e = p->screen_e, y = vec3_make(0, 1, 0), sc = p->screen_c;
    double S[12];
    vec3_t corners[4] = {vec3_add(sc, vec3_add(vec3_scale(e, -0.3), vec3_scale(y, -0.3))),
                         vec3_add(sc, vec3_add(vec3_scale(e, 0.3), vec3_scale(y, -0.3))),
                         vec3_add(sc, vec3_add(vec3_scale(e, 0.3), vec3_scale(y, 0.3))),
                         vec3_add(sc, vec3_add(vec3_scale(e, -0.3), vec3_scale(y, 0.3)))};
    for (int k = 0; k < 4; k++) {
        S[3 * k] = corners[k].x;
        S[3 * k + 1] = corners[k].y;
        S[3 * k + 2] = corners[k].z;
    }
    uint32_t sq[6] = {0, 1, 2, 0, 2, 3};
    p->screen = scene_add_mesh(s, S, 4, sq, 2, NULL, NULL, sb_diffuse(s, 0.8), -1, 0, NULL);
    assert_true(p->screen >= 0);
    sb_finish(s);
    return s;
}

/* ------------------------------------------------------------------------------------------ */
/* The caustic ball: a disk light of radius 0.8 and radiance 40 at height 8 above a glass ball
 * (n = 1.5, radius 1, centre 1.6 above the floor: the paraxial focus of a ball lens,
 * nR / (2(n - 1)) = 1.5 from its centre for a distant source) that focuses it onto a grey
 * (albedo 0.5) floor; the camera looks down at the floor under the ball from under its rim, so
 * the caustic fills the res x res image and every pixel is caustic (L S+ D E). The light is
 * small (7 degrees across from the ball) but finite, so that the path tracer converges at test
 * size. Path tracing with hero wavelengths, maxdepth 8, seed 5; with photons > 0 a photon pass
 * of that many photons (maxdepth 8, radius 0.02, no roulette threshold). */
static inline scene_t *sb_ball_build_on(scene_t *s, int photons, int res, int floor);

static inline scene_t *sb_ball_build(scene_t *s, int photons, int res)
{
    return sb_ball_build_on(s, photons, res, -1);
}

/* The caustic ball with material `floor` (an index of s's materials) on the floor instead of
 * the grey diffuse one (-1): a glossy receiver for the photons' L S+ G estimate. */
static inline scene_t *sb_ball_build_on(scene_t *s, int photons, int res, int floor)
{
    err_t err;
    render_settings_t *rs = &s->settings;
    rs->integrator = INTEGRATOR_PATH;
    rs->dispersion = DISPERSION_HERO;
    rs->visible_sampling = 0;
    rs->maxdepth = 8;
    rs->xres = rs->yres = res;
    rs->seed = 5;
    if (photons > 0) {
        rs->photon.enabled = 1;
        rs->photon.photons = (uint64_t)photons;
        rs->photon.maxdepth = 8;
        rs->photon.radius = 0.02;
        rs->photon.k = 0;
        rs->photon.threshold = 0.0;
    }
    transform_t cam;
    assert_int_equal(transform_look_at(vec3_make(0, 0.55, -1.1), vec3_make(0, 0, 0),
                                       vec3_make(0, 1, 0), &cam, &err),
                     0);
    s->camera.camera_to_world = transform_inverse(cam);
    s->camera.fov_deg = 20.0;
    const spectrum_t *white = sb_constant(s, 1.0);
    int fm = sb_diffuse(s, 0.5);
    material_t glass = {.kind = MATERIAL_DIELECTRIC};
    glass.ior = ior_constant(1.5);
    int gm = scene_add_material(s, &glass, &err);
    assert_true(gm >= 0);
    /* Floor: a large disk at y = 0 facing up (+z of the disk turned onto +y). */
    transform_t rx;
    assert_int_equal(transform_rotate(-90.0, vec3_make(1, 0, 0), &rx, &err), 0);
    assert_true(scene_add_disk(s, &rx, 20.0, 0.0, floor >= 0 ? floor : fm, -1, 0, &err) >= 0);
    transform_t ball = transform_translate(vec3_make(0, 1.6, 0));
    assert_true(scene_add_sphere(s, &ball, 1.0, gm, -1, 0, &err) >= 0);
    light_t l = {.kind = LIGHT_AREA, .spectrum = white, .scale = 40.0};
    int li = scene_add_light(s, &l, &err);
    assert_true(li >= 0);
    transform_t up = transform_compose(transform_translate(vec3_make(0, 8, 0)), rx);
    assert_true(scene_add_disk(s, &up, 0.8, 0.0, fm, li, 1, &err) >= 0);
    sb_finish(s);
    return s;
}

/* ------------------------------------------------------------------------------------------ */
/* Image statistics of one res x res tile rendered at spp samples per pixel. */

/* Per bucket, the mean over pixels and its standard error from the spread of pixel means
 * (pixels are independent estimates), of s rendered in one res x res tile at its own spp. */
typedef struct sb_bucket_stats {
    double mean[64];
    double se[64];
    uint64_t nonfinite;
} sb_bucket_stats_t;

static inline sb_bucket_stats_t sb_render_bucket_stats(scene_t *s, int res)
{
    err_t err;
    int nb = s->settings.grid.n;
    assert_true(nb <= 64);
    tilebuf_t *t = tilebuf_new(0, 0, res, res, nb, &err);
    assert_non_null(t);
    render_stats_t rs = {0};
    if (render_tile(s, NULL, 0, 0, res, res, 0, (uint32_t)s->settings.spp, t, &rs, &err))
        fail_msg("render_tile: %s", err.msg);
    sb_bucket_stats_t st = {.nonfinite = rs.nonfinite};
    int npix = res * res;
    for (int b = 0; b < nb; b++) {
        double sum = 0, sq = 0;
        for (int y = 0; y < res; y++)
            for (int x = 0; x < res; x++) {
                double m = tilebuf_sum(t, x, y, b) / (double)tilebuf_count(t, x, y);
                sum += m;
                sq += m * m;
            }
        st.mean[b] = sum / npix;
        st.se[b] = sqrt(fmax(0.0, sq / npix - st.mean[b] * st.mean[b]) / (npix - 1));
    }
    tilebuf_destroy(&t);
    return st;
}

typedef struct sb_image_stats {
    double mean;        /* mean over pixels of the pixel's mean luminance */
    double se;          /* its standard error from the per-sample variances */
    double max;         /* largest pixel mean */
    double var;         /* mean per-sample variance of luminance */
    double buckets[64]; /* mean spectral value per bucket */
} sb_image_stats_t;

/* The image statistics of s rendered at res x res and spp, its camera pass gathering from
 * photons (the store of its photon pass, NULL without one). */
static inline sb_image_stats_t sb_render_stats_with(scene_t *s, const photon_store_t *photons,
                                                    int res, int spp)
{
    err_t err;
    s->settings.spp = spp;
    int nb = s->settings.grid.n;
    assert_true(nb <= 64);
    tilebuf_t *t = tilebuf_new(0, 0, res, res, nb, &err);
    assert_non_null(t);
    render_stats_t rst = {0};
    if (render_tile(s, photons, 0, 0, res, res, 0, (uint32_t)spp, t, &rst, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(rst.nonfinite, 0);
    sb_image_stats_t st = {0};
    double var_sum = 0;
    for (int y = 0; y < res; y++)
        for (int x = 0; x < res; x++) {
            double n = (double)tilebuf_count(t, x, y);
            double m = tilebuf_luminance_sum(t, x, y) / n;
            double v = fmax(0.0, tilebuf_luminance_sq_sum(t, x, y) / n - m * m);
            st.mean += m;
            st.max = fmax(st.max, m);
            st.var += v;
            var_sum += v / n;
            for (int b = 0; b < nb; b++)
                st.buckets[b] += tilebuf_sum(t, x, y, b) / n / (res * res);
        }
    st.mean /= res * res;
    st.var /= res * res;
    st.se = sqrt(var_sum) / (res * res);
    tilebuf_destroy(&t);
    return st;
}

/* sb_render_stats_with the scene's own photon pass, traced on every core first if it has one. */
static inline sb_image_stats_t sb_render_stats(scene_t *s, int res, int spp)
{
    err_t err;
    photon_store_t *photons = NULL;
    if (s->settings.photon.enabled && !(photons = photon_pass_run(s, 0, NULL, NULL, &err)))
        fail_msg("photon pass: %s", err.msg);
    sb_image_stats_t st = sb_render_stats_with(s, photons, res, spp);
    photon_store_destroy(&photons);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Scenes loaded from pbrt-v4. */

/* The scene of a pbrt-v4 text (t.pbrt in messages) under the overrides ov (NULL: its own
 * settings). With err NULL it must load: an error fails the test, quoting the text; otherwise
 * NULL, and the error in *err. */
static inline scene_t *sb_load_text_with(const char *text, const scene_overrides_t *ov,
                                         err_t *err)
{
    err_t own = {{0}};
    err_t *e = err ? err : &own;
    scene_desc_t *d = pbrt_parse_string(text, strlen(text), "t.pbrt", e);
    if (!d && !err)
        fail_msg("parse: %s\n--\n%s", own.msg, text);
    if (!d)
        return NULL;
    scene_t *s = scene_load(d, ov, e);
    scene_desc_destroy(&d);
    if (!s && !err)
        fail_msg("load: %s\n--\n%s", own.msg, text);
    return s;
}

/* sb_load_text_with the text's own settings. */
static inline scene_t *sb_load_text(const char *text, err_t *err)
{
    return sb_load_text_with(text, NULL, err);
}

/* The scene of the pbrt-v4 file at path with its own settings (seed included); an error fails
 * the test. */
static inline scene_t *sb_load_file(const char *path)
{
    err_t err;
    scene_overrides_t ov = {.seed = -1};
    scene_t *s = scene_load_file(path, &ov, &err);
    if (!s)
        fail_msg("%s", err.msg);
    return s;
}

#endif
