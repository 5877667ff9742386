/* medium: participating media against numbers that do not come from the code -- the
 * Henyey-Greenstein phase function's normalisation and its sampling (chi-square against the
 * analytic distribution of the cosine, and of the azimuth), Beer-Lambert transmittance of a
 * homogeneous slab per wavelength, ratio and delta tracking of a density grid against the
 * grid's analytic optical depth, white furnaces (albedo 1, grey and chromatic, camera outside
 * and inside, isotropic and forward scattering) that must conserve energy, an emitting medium
 * whose radiance is its Le, a uniform grid rendering the mean of the homogeneous medium it
 * equals, numbers that stay finite for extreme coefficients, equiangular sampling (its sampler
 * against its density, and single scattering from a point and a small area light against
 * numerical integration, with its variance gain over free flight), and the pbrt-v4 syntax
 * (MakeNamedMedium, MediumInterface, presets, which integrators simulate media). Statistical
 * checks use fixed seeds and tolerances of 5 standard errors from the sample count. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "files.h"
#include "le_bytes.h"
#include "medium.h"
#include "nanovdb.h"
#include "numeric_testutil.h"
#include "phase_hg.h"
#include "photon_pass.h"
#include "photon_store.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"
#include "shading.h"
#include "equiangular.h"
#include "rng.h"
#include "volume.h"

/* ---- the phase function ---- */

static const double GS[] = {-0.95, -0.5, 0.0, 0.3, 0.8, 0.99};

/* The cumulative distribution of x = wo . wi under HG, from integrating
 * 2 pi (1 - g^2) / (4 pi (1 + g^2 + 2 g x)^(3/2)) over [-1, x]:
 * F(x) = (1 - g^2) / (2 g) (1 / (1 - g) - 1 / sqrt(1 + g^2 + 2 g x)); (x + 1) / 2 at g = 0. */
static double hg_cdf(double x, double g)
{
    if (g == 0.0)
        return 0.5 * (x + 1.0);
    return (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 - g) - 1.0 / sqrt(1.0 + g * g + 2.0 * g * x));
}

static void test_hg_normalised(void **state)
{
    (void)state;
    const vec3_t wo = vec3_normalize(vec3_make(0.3, -0.2, 0.9));
    vec3_t t, b;
    vec3_basis(wo, &t, &b);
    for (size_t i = 0; i < sizeof GS / sizeof GS[0]; i++) {
        /* Midpoint rule over x = cos in [-1, 1], times 2 pi for the azimuth. */
        const int n = 400000;
        double sum = 0.0;
        for (int k = 0; k < n; k++) {
            double x = -1.0 + (k + 0.5) * 2.0 / n, s = sqrt(1.0 - x * x);
            vec3_t wi = vec3_add(vec3_scale(wo, x), vec3_scale(t, s));
            sum += phase_hg_eval(wo, wi, GS[i]) * 2.0 / n;
        }
        testutil_assert_near(2.0 * PF_PI * sum, 1.0, 2e-3);
        /* Forward scattering (g > 0) favours wi = -wo. */
        if (GS[i] > 0.0)
            assert_true(phase_hg_eval(wo, vec3_neg(wo), GS[i]) > phase_hg_eval(wo, wo, GS[i]));
    }
    /* |g| -> 1 is clamped: finite everywhere, never NaN. */
    const double extreme[] = {1.0, -1.0, 0.999999999, NAN};
    for (size_t i = 0; i < 4; i++) {
        double p0 = phase_hg_eval(wo, vec3_neg(wo), extreme[i]), p1 = phase_hg_eval(wo, wo, extreme[i]);
        assert_true(isfinite(p0) && p0 >= 0.0 && isfinite(p1) && p1 >= 0.0);
        double pdf;
        vec3_t wi = phase_hg_sample(wo, extreme[i], 0.5, 0.5, &pdf);
        assert_true(isfinite(pdf) && pdf > 0.0 && fabs(vec3_length(wi) - 1.0) < 1e-12);
    }
}

/* Samples binned into K bins of equal probability under the analytic distribution of the
 * cosine (x_k = F^-1(k / K), F inverted by bisection), and their azimuths about wo into K
 * equal sectors: both chi-square statistics below the 1e-6 upper tail. The pdf a sample
 * reports is phase_hg_eval's. */
static void test_hg_sampling_chi2(void **state)
{
    (void)state;
    enum { K = 40, N = 400000 };
    const vec3_t wo = vec3_normalize(vec3_make(-0.5, 0.7, 0.1));
    vec3_t t, b;
    vec3_basis(wo, &t, &b);
    uint64_t rng = 12345;
    for (size_t i = 0; i < sizeof GS / sizeof GS[0]; i++) {
        const double g = GS[i];
        double edge[K + 1];
        edge[0] = -1.0;
        edge[K] = 1.0;
        for (int k = 1; k < K; k++) {
            double lo = -1.0, hi = 1.0;
            for (int it = 0; it < 200; it++) {
                double mid = 0.5 * (lo + hi);
                if (hg_cdf(mid, g) < (double)k / K)
                    lo = mid;
                else
                    hi = mid;
            }
            edge[k] = 0.5 * (lo + hi);
        }
        long cnt[K] = {0}, az[K] = {0};
        for (int s = 0; s < N; s++) {
            double pdf;
            vec3_t wi = phase_hg_sample(wo, g, testutil_splitmix_u(&rng), testutil_splitmix_u(&rng), &pdf);
            testutil_assert_near(pdf, phase_hg_eval(wo, wi, g), 1e-9 * pdf);
            double x = vec3_dot(wo, wi);
            int k = 0;
            while (k < K - 1 && x > edge[k + 1])
                k++;
            cnt[k]++;
            double phi = atan2(vec3_dot(wi, b), vec3_dot(wi, t)) + PF_PI;
            int a = (int)(phi / (2.0 * PF_PI) * K);
            az[a < 0 ? 0 : a >= K ? K - 1 : a]++;
        }
        double chi = 0.0, chi_az = 0.0, e = (double)N / K;
        for (int k = 0; k < K; k++) {
            chi += (cnt[k] - e) * (cnt[k] - e) / e;
            chi_az += (az[k] - e) * (az[k] - e) / e;
        }
        double bound = testutil_chi2_quantile(K - 1, 4.75);
        if (!(chi < bound) || !(chi_az < bound))
            fail_msg("g %g: chi-square %.1f (cosine), %.1f (azimuth), bound %.1f", g, chi, chi_az, bound);
    }
}

/* ---- media built through the API ---- */

/* A spectrum linear in wavelength from a at 360 nm to b at 830 nm, owned by s. */
static const spectrum_t *ramp(scene_t *s, double a, double b)
{
    err_t err;
    const double l[2] = {360.0, 830.0}, v[2] = {a, b};
    spectrum_t *sp = spectrum_new_tabulated(l, v, 2, &err);
    assert_non_null(sp);
    assert_int_equal(scene_own_spectrum(s, sp, &err), 0);
    return sp;
}

static int add_homogeneous(scene_t *s, const spectrum_t *sa, const spectrum_t *ss, double scale, double g)
{
    err_t err;
    medium_params_t p = {.sigma_a = sa, .sigma_s = ss, .scale = scale, .g = g, .Le_scale = 1.0};
    medium_t *m = medium_new_homogeneous(&p, &err);
    if (!m)
        fail_msg("%s", err.msg);
    int i = scene_add_medium(s, m, &err);
    assert_true(i >= 0);
    return i;
}

/* An axis-aligned quad at z = z0 over [-5, 5]^2 with an "interface" material, its normal +z or
 * -z (outward from the slab), between medium `inside` and vacuum. */
static void add_interface_quad(scene_t *s, double z0, double nz, int inside)
{
    err_t err;
    const double P[12] = {-5, -5, z0, 5, -5, z0, 5, 5, z0, -5, 5, z0};
    const uint32_t up[6] = {0, 1, 2, 0, 2, 3}, down[6] = {0, 2, 1, 0, 3, 2};
    int mi = sb_material(s, MATERIAL_INTERFACE, NULL);
    int r = scene_add_mesh(s, P, 4, nz > 0 ? up : down, 2, NULL, NULL, mi, -1, 0, &err);
    assert_true(r >= 0);
    s->shapes[r].medium_inside = inside;
    s->shapes[r].medium_outside = -1;
}

static const double LAMBDA[4] = {400.0, 480.0, 610.0, 760.0};

/* A shadow ray through a slab of thickness d between two interface quads: exactly
 * exp(-sigma_t(lambda) d) per wavelength (a homogeneous medium's transmittance is evaluated
 * in closed form), the ray entering and leaving through the boundaries' medium rule. */
static void test_beer_lambert_slab(void **state)
{
    (void)state;
    scene_t *s = sb_new_scene();
    const double d = 1.7, scale = 0.8;
    int m = add_homogeneous(s, ramp(s, 0.2, 1.0), ramp(s, 1.5, 0.1), scale, 0.0);
    add_interface_quad(s, 0.0, -1.0, m);
    add_interface_quad(s, d, 1.0, m);
    sb_finish(s);
    assert_true(s->has_medium_boundary);
    rng_stream_t rng = rng_stream_make(1, 2, 3);
    double T[4];
    vec3_t dir = vec3_normalize(vec3_make(0.3, 0.1, 1.0));
    vec3_t org = vec3_make(0, 0, -1.0);
    double tmax = 3.5 / dir.z;
    assert_int_equal(shading_transmittance(s, org, dir, tmax, -1, LAMBDA, 4, &rng, T), 1);
    for (int j = 0; j < 4; j++) {
        double f = (LAMBDA[j] - 360.0) / 470.0;
        double st = scale * ((0.2 + 0.8 * f) + (1.5 - 1.4 * f));
        double expect = exp(-st * d / dir.z);
        /* to the boundaries' offsets (geometry_offset): a few 1e-7 of the optical depth */
        testutil_assert_near(T[j], expect, 1e-5 * expect);
    }
    /* A shadow ray starting inside the slab leaves it once. */
    assert_int_equal(shading_transmittance(s, vec3_make(0, 0, 1.0), vec3_make(0, 0, 1), 5.0, m, LAMBDA, 4, &rng, T), 1);
    for (int j = 0; j < 4; j++) {
        double f = (LAMBDA[j] - 360.0) / 470.0;
        double st = scale * ((0.2 + 0.8 * f) + (1.5 - 1.4 * f));
        testutil_assert_near(T[j], exp(-st * (d - 1.0)), 1e-5);
    }
    scene_destroy(&s);
}

/* The free flight through a homogeneous medium reaches distance d with probability and
 * weight whose product averages exp(-sigma_t,j d) for every lane, whichever lane decides
 * (unequal throughputs make the lanes' shares unequal). */
static void test_homogeneous_flight(void **state)
{
    (void)state;
    scene_t *s = sb_new_scene();
    int mi = add_homogeneous(s, ramp(s, 0.1, 2.0), ramp(s, 2.0, 0.2), 1.0, 0.5);
    const medium_t *m = s->media[mi];
    volume_lanes_t k;
    volume_lanes_make(m, LAMBDA, 4, &k);
    const double beta[4] = {1.0, 0.3, 2.0, 0.05};
    const double d = 0.9;
    enum { N = 400000 };
    double sum[4] = {0}, sq[4] = {0};
    rng_stream_t rng = rng_stream_make(9, 9, 9);
    volume_flight_t f;
    for (int i = 0; i < N; i++) {
        volume_sample(m, &k, vec3_make(0, 0, 0), vec3_make(1, 0, 0), d, beta, &rng, &f);
        for (int j = 0; j < 4; j++) {
            double v = f.event == VOLUME_PASSED ? f.weight[j] : 0.0;
            assert_true(isfinite(v) && v >= 0.0);
            sum[j] += v;
            sq[j] += v * v;
        }
    }
    for (int j = 0; j < 4; j++) {
        double mean = sum[j] / N, se = sqrt(fmax(0.0, sq[j] / N - mean * mean) / N);
        double expect = exp(-(k.sigma_a[j] + k.sigma_s[j]) * d);
        if (!(fabs(mean - expect) <= 5.0 * se + 1e-12))
            fail_msg("lane %d: %.5f +- %.5f, expected %.5f", j, mean, se, expect);
    }
    scene_destroy(&s);
}

/* A 4 x 1 x 1 grid over x in [0, L]: on the box's centre line its density is the piecewise
 * linear interpolation of the samples at the voxel centres, 0 beyond the outer centres' half
 * voxel toward the faces (pbrt-v4 SampledGrid), so the integral along the whole line is
 * L (7/32 (d0 + d3) + 1/4 (d1 + d2)): each inner hat has area 1/4 of the box, each outer one
 * loses the 1/32 outside it. Ratio tracking and delta tracking both average
 * exp(-sigma_t,j times that) per lane; so does a transformed copy of the grid. */
static void test_grid_tracking(void **state)
{
    (void)state;
    scene_t *s = sb_new_scene();
    const double dens[4] = {0.0, 2.0, 0.5, 3.0};
    const double L = 2.0;
    err_t err;
    medium_params_t p = {.sigma_a = ramp(s, 0.3, 1.2), .sigma_s = ramp(s, 0.9, 0.2), .scale = 1.0, .Le_scale = 1.0};
    transform_t moved = transform_translate(vec3_make(5, -1, 2));
    const transform_t *tr[2] = {NULL, &moved};
    for (int c = 0; c < 2; c++) {
        transform_t id = transform_identity();
        medium_t *m = medium_new_grid(&p, 4, 1, 1, dens, vec3_make(0, 0, 0), vec3_make(L, 1, 1), tr[c] ? tr[c] : &id, &err);
        if (!m)
            fail_msg("%s", err.msg);
        vec3_t off = tr[c] ? vec3_make(5, -1, 2) : vec3_make(0, 0, 0);
        /* the density at a few points of the centre line against the hats */
        testutil_assert_near(medium_density(m, vec3_add(off, vec3_make(0.25 * L, 0.5, 0.5))), 0.5 * (dens[0] + dens[1]), 1e-12);
        testutil_assert_near(medium_density(m, vec3_add(off, vec3_make(1.5 * L / 4, 0.5, 0.5))), dens[1], 1e-12);
        testutil_assert_near(medium_density(m, vec3_add(off, vec3_make(L, 0.5, 0.5))), 0.5 * dens[3], 1e-12);
        testutil_assert_near(medium_density(m, vec3_add(off, vec3_make(L + 0.01, 0.5, 0.5))), 0.0, 0.0);
        volume_lanes_t k;
        volume_lanes_make(m, LAMBDA, 4, &k);
        const double integral = L * (7.0 / 32.0 * (dens[0] + dens[3]) + 0.25 * (dens[1] + dens[2]));
        const double beta[4] = {1, 1, 1, 1};
        enum { N = 200000 };
        double rs[4] = {0}, rq[4] = {0}, ds[4] = {0}, dq[4] = {0};
        rng_stream_t rng = rng_stream_make(3, (uint64_t)c, 1);
        volume_flight_t f;
        vec3_t org = vec3_add(off, vec3_make(-1.0, 0.5, 0.5)), dir = vec3_make(1, 0, 0);
        for (int i = 0; i < N; i++) {
            double T[4] = {1, 1, 1, 1};
            volume_transmittance(m, &k, org, dir, L + 3.0, &rng, T);
            volume_sample(m, &k, org, dir, L + 3.0, beta, &rng, &f);
            for (int j = 0; j < 4; j++) {
                double v = f.event == VOLUME_PASSED ? f.weight[j] : 0.0;
                assert_true(isfinite(T[j]) && T[j] >= 0.0 && isfinite(v) && v >= 0.0);
                rs[j] += T[j];
                rq[j] += T[j] * T[j];
                ds[j] += v;
                dq[j] += v * v;
            }
        }
        for (int j = 0; j < 4; j++) {
            double expect = exp(-(k.sigma_a[j] + k.sigma_s[j]) * integral);
            double rm = rs[j] / N, rse = sqrt(fmax(0.0, rq[j] / N - rm * rm) / N);
            double dm = ds[j] / N, dse = sqrt(fmax(0.0, dq[j] / N - dm * dm) / N);
            if (!(fabs(rm - expect) <= 5.0 * rse) || !(fabs(dm - expect) <= 5.0 * dse))
                fail_msg("grid %d lane %d: ratio %.5f +- %.5f, delta %.5f +- %.5f, analytic %.5f", c, j, rm,
                         rse, dm, dse, expect);
        }
        medium_destroy(&m);
    }
    /* An all-zero grid is clear: transmittance exactly 1, every flight passes with weight 1. */
    const double zero[8] = {0};
    transform_t id = transform_identity();
    medium_t *z = medium_new_grid(&p, 2, 2, 2, zero, vec3_make(0, 0, 0), vec3_make(1, 1, 1), &id, &err);
    assert_non_null(z);
    volume_lanes_t k;
    volume_lanes_make(z, LAMBDA, 4, &k);
    double T[4] = {1, 1, 1, 1};
    rng_stream_t rng = rng_stream_make(1, 1, 1);
    volume_transmittance(z, &k, vec3_make(-1, 0.5, 0.5), vec3_make(1, 0, 0), 10.0, &rng, T);
    const double one[4] = {1, 1, 1, 1};
    volume_flight_t f;
    volume_sample(z, &k, vec3_make(-1, 0.5, 0.5), vec3_make(1, 0, 0), 10.0, one, &rng, &f);
    assert_int_equal(f.event, VOLUME_PASSED);
    for (int j = 0; j < 4; j++) {
        assert_true(T[j] == 1.0);
        assert_true(f.weight[j] == 1.0);
    }
    medium_destroy(&z);
    /* Bad grids are refused with a message. */
    const double neg[1] = {-1.0};
    assert_null(medium_new_grid(&p, 1, 1, 1, neg, vec3_make(0, 0, 0), vec3_make(1, 1, 1), &id, &err));
    assert_non_null(strstr(err.msg, "density"));
    assert_null(medium_new_grid(&p, 1, 1, 1, one, vec3_make(0, 0, 0), vec3_make(1, 0, 1), &id, &err));
    assert_non_null(strstr(err.msg, "p1 > p0"));
    scene_destroy(&s);
}

/* ---- rendered ---- */

enum { RES = 8 };

/* A uniform environment of radiance 1 (the furnace), the camera at (0, 0, -5) toward the
 * origin, media simulated by the path tracer. */
static scene_t *furnace_scene(int spp, dispersion_kind_t disp)
{
    err_t err;
    scene_t *s = sb_render_scene(INTEGRATOR_PATH, disp, RES, spp);
    s->settings.media = 1;
    sb_look_at(s, vec3_make(0, 0, -5), vec3_make(0, 0, 0), 30);
    light_t l = {.kind = LIGHT_INFINITE, .spectrum = sb_constant(s, 1.0), .scale = 1.0};
    assert_true(scene_add_light(s, &l, &err) >= 0);
    return s;
}

static void add_medium_sphere(scene_t *s, double radius, int inside, int outside)
{
    err_t err;
    transform_t id = transform_identity();
    int r = scene_add_sphere(s, &id, radius, sb_material(s, MATERIAL_INTERFACE, NULL), -1, 0, &err);
    assert_true(r >= 0);
    s->shapes[r].medium_inside = inside;
    s->shapes[r].medium_outside = outside;
}

/* Renders s at RES x RES and spp and checks every bucket's image mean against expect within 5
 * standard errors (from the spread of the pixels' means: pixels are independent estimates)
 * plus abs_tol. */
static void assert_every_bucket(scene_t *s, int spp, double expect, double abs_tol, const char *what)
{
    err_t err;
    const int nb = s->settings.grid.n;
    s->settings.spp = spp;
    tilebuf_t *t = tilebuf_new(0, 0, RES, RES, nb, &err);
    assert_non_null(t);
    render_stats_t rs = {0};
    if (render_tile(s, NULL, 0, 0, RES, RES, 0, (uint32_t)spp, t, &rs, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(rs.nonfinite, 0);
    double worst = 0.0;
    for (int b = 0; b < nb; b++) {
        double sum = 0.0, sq = 0.0;
        for (int y = 0; y < RES; y++)
            for (int x = 0; x < RES; x++) {
                double m = tilebuf_sum(t, x, y, b) / (double)tilebuf_count(t, x, y);
                sum += m;
                sq += m * m;
            }
        const int n = RES * RES;
        double mean = sum / n, se = sqrt(fmax(0.0, sq / n - mean * mean) / (n - 1));
        worst = fmax(worst, fabs(mean - expect) / (se > 0.0 ? se : 1e-300));
        if (!(fabs(mean - expect) <= 5.0 * se + abs_tol))
            fail_msg("%s: bucket %d is %.5f +- %.5f, expected %.5f", what, b, mean, se, expect);
    }
    printf("%s: worst bucket %.2f standard errors off\n", what, worst);
    tilebuf_destroy(&t);
}

/* White furnaces: a medium that scatters without absorbing (albedo 1 at every wavelength,
 * though sigma_s varies eightfold over the spectrum) inside a closed environment of radiance
 * 1 neither adds nor removes light: every bucket of every pixel is 1. Seen from outside and
 * from inside, isotropic and strongly forward-scattering, homogeneous and a grid, with hero
 * wavelengths and with the thesis's 16 fan-out lanes. The tolerance is 5 standard errors of a
 * bucket's mean plus 1e-3 for the light still inside after maxdepth 64 bounces (optical depth
 * at most 4: far less than that). */
static void test_white_furnace(void **state)
{
    (void)state;
    struct {
        const char *what;
        double ss_a, ss_b, g;
        int camera_inside, grid;
        dispersion_kind_t disp;
    } cases[] = {
        {"grey, isotropic, outside", 2.0, 2.0, 0.0, 0, 0, DISPERSION_HERO},
        {"chromatic, g 0.7, outside", 0.5, 4.0, 0.7, 0, 0, DISPERSION_HERO},
        {"chromatic, g -0.4, camera inside", 0.6, 0.08, -0.4, 1, 0, DISPERSION_HERO},
        {"chromatic grid, g 0.3, outside", 0.5, 4.0, 0.3, 0, 1, DISPERSION_HERO},
        /* 16 fan-out lanes, one per bucket, share each flight */
        {"chromatic, fan-out lanes", 0.5, 4.0, 0.2, 0, 0, DISPERSION_FANOUT},
        {"chromatic grid, fan-out lanes", 0.5, 4.0, 0.2, 0, 1, DISPERSION_FANOUT},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        scene_t *s = furnace_scene(64, cases[c].disp);
        const spectrum_t *zero = sb_constant(s, 0.0), *ss = ramp(s, cases[c].ss_a, cases[c].ss_b);
        int m;
        if (cases[c].grid) {
            err_t err;
            /* a bumpy density over a box larger than the sphere */
            double d[27];
            for (int i = 0; i < 27; i++)
                d[i] = 0.2 + (double)((i * 7) % 5) * 0.4;
            medium_params_t p = {.sigma_a = zero, .sigma_s = ss, .scale = 1.0, .g = cases[c].g, .Le_scale = 1.0};
            transform_t id = transform_identity();
            medium_t *gm = medium_new_grid(&p, 3, 3, 3, d, vec3_make(-1.2, -1.2, -1.2), vec3_make(1.2, 1.2, 1.2), &id, &err);
            assert_non_null(gm);
            m = scene_add_medium(s, gm, &err);
        } else {
            m = add_homogeneous(s, zero, ss, 1.0, cases[c].g);
        }
        if (cases[c].camera_inside) {
            add_medium_sphere(s, 5.5, m, -1);
            s->camera_medium = m;
        } else {
            add_medium_sphere(s, 1.0, m, -1);
        }
        sb_finish(s);
        assert_every_bucket(s, 64, 1.0, 1e-3, cases[c].what);
        scene_destroy(&s);
    }
}

/* An unbounded absorbing medium of emission Le around the camera, no light, no surface: the
 * radiance is int_0^inf sigma_a exp(-sigma_a t) Le dt = Le in every direction, whatever
 * sigma_a(lambda) (here chromatic, so the lanes' shares differ). */
static void test_emission(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = sb_render_scene(INTEGRATOR_PATH, DISPERSION_HERO, RES, 32);
    s->settings.media = 1;
    medium_params_t p = {.sigma_a = ramp(s, 0.05, 3.0), .sigma_s = sb_constant(s, 0.0), .scale = 1.0,
                         .Le = sb_constant(s, 2.0), .Le_scale = 1.5};
    medium_t *m = medium_new_homogeneous(&p, &err);
    assert_non_null(m);
    s->camera_medium = scene_add_medium(s, m, &err);
    sb_finish(s);
    assert_every_bucket(s, 32, 3.0, 1e-9, "emission");
    scene_destroy(&s);
}

/* A scene lit by a point light and the environment over a diffuse floor, with a fog sphere
 * between: as a homogeneous medium, and as a uniform grid of density 1 whose box is larger
 * than the sphere (inside the sphere the grid is exactly 1). Both render the same mean. */
static scene_t *fog_scene(int grid, double scale, double g)
{
    err_t err;
    scene_t *s = sb_render_scene(INTEGRATOR_PATH, DISPERSION_HERO, RES, 64);
    s->settings.media = 1;
    s->settings.maxdepth = 16;
    sb_look_at(s, vec3_make(0, 1, -6), vec3_make(0, 0, 0), 35);
    light_t env = {.kind = LIGHT_INFINITE, .spectrum = sb_constant(s, 0.3), .scale = 1.0};
    assert_true(scene_add_light(s, &env, &err) >= 0);
    light_t pt = {.kind = LIGHT_POINT, .spectrum = sb_constant(s, 1.0), .scale = 30.0, .position = vec3_make(1, 4, -1)};
    assert_true(scene_add_light(s, &pt, &err) >= 0);
    const double P[12] = {-10, -1, -10, 10, -1, -10, 10, -1, 10, -10, -1, 10};
    const uint32_t I[6] = {0, 2, 1, 0, 3, 2};
    assert_true(scene_add_mesh(s, P, 4, I, 2, NULL, NULL, sb_diffuse(s, 0.6), -1, 0, &err) >= 0);
    medium_params_t p = {.sigma_a = ramp(s, 0.4, 0.05), .sigma_s = ramp(s, 0.5, 2.0), .scale = scale, .g = g,
                         .Le_scale = 1.0};
    medium_t *m;
    if (grid) {
        double ones[64];
        for (int i = 0; i < 64; i++)
            ones[i] = 1.0;
        transform_t id = transform_identity();
        m = medium_new_grid(&p, 4, 4, 4, ones, vec3_make(-2, -2, -2), vec3_make(2, 2, 2), &id, &err);
    } else {
        m = medium_new_homogeneous(&p, &err);
    }
    assert_non_null(m);
    add_medium_sphere(s, 0.9, scene_add_medium(s, m, &err), -1);
    sb_finish(s);
    return s;
}

static void test_grid_equals_homogeneous(void **state)
{
    (void)state;
    scene_t *h = fog_scene(0, 3.0, 0.4), *g = fog_scene(1, 3.0, 0.4);
    g->settings.seed = 99;
    sb_image_stats_t a = sb_render_stats(h, RES, 256), b = sb_render_stats(g, RES, 256);
    printf("homogeneous %.5f +- %.5f, grid %.5f +- %.5f\n", a.mean, a.se, b.mean, b.se);
    double tol = 5.0 * sqrt(a.se * a.se + b.se * b.se);
    if (!(fabs(a.mean - b.mean) <= tol))
        fail_msg("homogeneous %.5f +- %.5f, grid %.5f +- %.5f", a.mean, a.se, b.mean, b.se);
    /* and the medium is visible: without it the mean differs by more than 5 standard errors */
    h->settings.media = 0;
    sb_image_stats_t c = sb_render_stats(h, RES, 256);
    printf("without the medium %.5f +- %.5f\n", c.mean, c.se);
    assert_true(fabs(c.mean - a.mean) > 5.0 * sqrt(a.se * a.se + c.se * c.se));
    scene_destroy(&h);
    scene_destroy(&g);
}

/* Huge and tiny coefficients, g at the clamp, keep every sample finite (sb_render_stats fails
 * on a non-finite sample). */
static void test_extremes_finite(void **state)
{
    (void)state;
    const double scales[] = {1e-300, 1e-12, 1e6, 1e200};
    const double gs[] = {0.99999, -0.99999, 0.0, 0.9999};
    for (int i = 0; i < 4; i++) {
        for (int grid = 0; grid < 2; grid++) {
            scene_t *s = fog_scene(grid, scales[i], gs[i]);
            sb_image_stats_t st = sb_render_stats(s, RES, 16);
            assert_true(isfinite(st.mean) && st.mean >= 0.0);
            scene_destroy(&s);
        }
    }
}

/* ---- NanoVDB grids ---- */

/* tests/data/scenes/cloud_ref.nvdb was written by OpenVDB's own NanoVDB library
 * (tools/gen_nanovdb_ref.cpp: Debian's libnanovdb-dev 10.0.1, the ZIP codec), so the reader is
 * checked against the reference writer, and its sampler against the reference sampler's
 * values the tool printed. A "density" grid of 12^3 voxels at index (-3..8, 5..16, 9..20),
 * voxel size 0.25, origin (0.5, -1, 2), the values cloud_density (zero in a border of two
 * voxels), and a "temperature" grid of 4^3 voxels at 1000 + 100 i. */
static const char *CLOUD_REF = "data/scenes/cloud_ref.nvdb";

static double cloud_density(int a, int b, int c)
{
    if (a < 2 || b < 2 || c < 2 || a > 9 || b > 9 || c > 9)
        return 0.0;
    return 0.5 + 0.25 * (a % 3) + 0.125 * (b % 2) + 0.0625 * c;
}

static uint8_t *read_all(const char *path, size_t *len)
{
    err_t err;
    uint8_t *b;
    if (files_read(path, (size_t)1 << 26, &b, len, &err))
        fail_msg("%s", err.msg);
    return b;
}

static nanovdb_grid_t *read_grid(const uint8_t *b, size_t len, const char *name)
{
    err_t err;
    nanovdb_grid_t *g;
    uint64_t v;
    if (nanovdb_read(b, len, name, 0, &g, &v, &err))
        fail_msg("%s", err.msg);
    return g;
}

static void test_nanovdb_reference(void **state)
{
    (void)state;
    size_t len;
    uint8_t *b = read_all(CLOUD_REF, &len);
    nanovdb_grid_t *g = read_grid(b, len, "density");
    assert_non_null(g);
    vec3_t lo, hi;
    nanovdb_bounds(g, &lo, &hi);
    testutil_assert_near(lo.x, -0.25, 1e-12);
    testutil_assert_near(lo.z, 4.25, 1e-12);
    testutil_assert_near(hi.y, 3.25, 1e-12);
    /* the reference sampler (SampleFromVoxels<1>) at the tool's points */
    testutil_assert_near(nanovdb_sample(g, vec3_make(0.3, 0.6, 5.2)), 0.455000073, 1e-6);
    testutil_assert_near(nanovdb_sample(g, vec3_make(0.55, 1.8, 5.6)), 0.912499964, 1e-6);
    testutil_assert_near(nanovdb_sample(g, vec3_make(1.0, 0.3, 3.9)), 0.0, 0);
    /* every voxel, at its own index point */
    for (int a = 0; a < 12; a++)
        for (int c = 0; c < 12; c++)
            for (int bb = 0; bb < 12; bb++) {
                vec3_t p = vec3_make(0.5 + 0.25 * (a - 3), -1.0 + 0.25 * (bb + 5), 2.0 + 0.25 * (c + 9));
                testutil_assert_near(nanovdb_sample(g, p), cloud_density(a, bb, c), 1e-6);
            }
    nanovdb_grid_t *t = read_grid(b, len, "temperature");
    assert_non_null(t);
    testutil_assert_near(nanovdb_sample(t, vec3_make(1.5, 0.5, 0.5)), 1150.0, 1e-4);
    assert_null(read_grid(b, len, "smoke")); /* no such grid: not an error */
    nanovdb_destroy(&g);
    nanovdb_destroy(&t);
    free(b);
}

/* The reference file rewritten uncompressed (the codec NONE), so that its bytes can be
 * damaged where the layout says. *grid0: where the density grid's bytes start. */
static uint8_t *uncompressed_copy(size_t *out_len, size_t *grid0)
{
    size_t len;
    uint8_t *z = read_all(CLOUD_REF, &len);
    unsigned n = le_get_u16(z + 12);
    size_t rec = 16, body;
    uint64_t total = rec;
    for (unsigned i = 0; i < n; i++) {
        total += 176 + le_get_u32(z + rec + 136) + le_get_u64(z + rec);
        rec += 176 + le_get_u32(z + rec + 136);
    }
    body = rec;
    uint8_t *o = calloc(1, total);
    assert_non_null(o);
    memcpy(o, z, body);
    le_put_u16(o + 14, 0);
    size_t at = body, zat = body;
    rec = 16;
    for (unsigned i = 0; i < n; i++) {
        uint64_t gsize = le_get_u64(z + rec), zsize = le_get_u64(z + zat);
        uLongf outn = (uLongf)gsize;
        assert_int_equal(uncompress(o + at, &outn, z + zat + 8, (uLong)zsize), Z_OK);
        le_put_u64(o + rec + 8, gsize);
        le_put_u16(o + rec + 168, 0);
        at += gsize;
        zat += 8 + zsize;
        rec += 176 + le_get_u32(z + rec + 136);
    }
    free(z);
    *out_len = total;
    *grid0 = body;
    return o;
}

/* Reads a damaged copy; expects a refusal whose message holds `needle`. */
static void expect_refused(const uint8_t *b, size_t len, uint64_t budget, const char *needle)
{
    err_t err = {{0}};
    nanovdb_grid_t *g = NULL;
    uint64_t v;
    int rc = nanovdb_read(b, len, "density", budget, &g, &v, &err);
    if (rc == 0 || !strstr(err.msg, needle))
        fail_msg("expected a refusal with \"%s\", got rc %d: %s", needle, rc, rc ? err.msg : "");
    assert_null(g);
}

/* Damaged files are refused with the byte at fault, never read past their ends, never walked
 * forever: a bad magic number or version, a grid of doubles, a grid claiming more than it may,
 * a non-finite voxel, a node reached twice (a loop would be), a child pointing at no node, a
 * root table running past the grid, the voxel budget, and every truncation; then random byte
 * flips (the sanitizer build checks that nothing is read out of bounds). */
static void test_nanovdb_damaged(void **state)
{
    (void)state;
    size_t len, B;
    uint8_t *o = uncompressed_copy(&len, &B);
    nanovdb_grid_t *g = read_grid(o, len, "density");
    testutil_assert_near(nanovdb_sample(g, vec3_make(0.3, 0.6, 5.2)), 0.455000073, 1e-6);
    nanovdb_destroy(&g);
    uint8_t *d = malloc(len);
    assert_non_null(d);
#define DAMAGE(stmt, budget, needle)                                                                                   \
    do {                                                                                                               \
        memcpy(d, o, len);                                                                                             \
        stmt;                                                                                                          \
        expect_refused(d, len, budget, needle);                                                                        \
    } while (0)
    const size_t tree = B + 672;
    const size_t leaf0 = tree + le_get_u64(o + tree), lower0 = tree + le_get_u64(o + tree + 8);
    const size_t root = tree + le_get_u64(o + tree + 24);
    DAMAGE(d[0] ^= 1, 0, "not a NanoVDB file");
    DAMAGE(le_put_u32(d + 8, 31u << 21), 0, "this reader knows version 32");
    DAMAGE(le_put_u32(d + 16 + 32, 2), 0, "only float grids");
    DAMAGE(le_put_u64(d + 16, (uint64_t)3 << 30), 0, "at most");
    DAMAGE(le_put_f32(d + leaf0 + 96 + 4 * 77, NAN), 0, "voxel value 77 of a leaf is nan");
    DAMAGE(le_put_u32(d + root + 24, 0xFFFFFFFFu), 0, "run past");
    {
        /* a lower node's second entry made a child too, pointing at the first's leaf */
        int e1 = -1, e2 = -1;
        for (int e = 0; e < 4096 && (e1 < 0 || e2 < 0); e++) {
            int set = o[lower0 + 544 + e / 8] >> (e % 8) & 1;
            if (set && e1 < 0)
                e1 = e;
            if (!set && e2 < 0)
                e2 = e;
        }
        assert_true(e1 >= 0 && e2 >= 0);
        DAMAGE(le_put_u64(d + lower0 + 1088 + 8 * e1, 8), 0, "points at no leaf");
        DAMAGE((memcpy(d + lower0 + 1088 + 8 * e2, d + lower0 + 1088 + 8 * e1, 8),
                d[lower0 + 544 + e2 / 8] |= (uint8_t)(1u << (e2 % 8))),
               0, "reached twice");
    }
    DAMAGE((void)0, 1000, "--max-texels");
#undef DAMAGE
    /* every truncation is refused */
    for (size_t n = 0; n < len; n += 4093)
        expect_refused(o, n, 0, "");
    /* random flips in the grid's header and tree (fixed seed): refused or read, never unsafe,
     * and a grid read gives finite values */
    uint64_t x = 0x9E3779B97F4A7C15ULL;
    for (int i = 0; i < 300; i++) {
        memcpy(d, o, len);
        for (int k = 0; k < 4; k++) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            size_t at = (i % 3 == 0) ? (size_t)(x >> 33) % len : B + (size_t)(x >> 33) % (1000 + 4096 * 3);
            d[at < len ? at : len - 1] ^= (uint8_t)(1u << ((x >> 20) & 7));
        }
        err_t err = {{0}};
        uint64_t v;
        if (nanovdb_read(d, len, "density", 1u << 19, &g, &v, &err) == 0 && g) {
            assert_true(isfinite(nanovdb_sample(g, vec3_make(0.3, 0.6, 5.2))));
            nanovdb_destroy(&g);
        } else if (g == NULL) {
            assert_true(err.msg[0] != 0 || v == 0);
        }
    }
    free(d);
    free(o);
}

/* The reference grid as a pbrt-v4 "nanovdb" medium and the same density as a "uniformgrid"
 * (12^3 samples at the voxels' points: p0 half a voxel below the first), both moved to the
 * origin, inside an interface sphere under a point light and an environment: the density is
 * the same at every point, the majorant cells bound it, and the images have the same mean. */
static scene_t *cloud_scene(int vdb)
{
    err_t err;
    scene_t *s = sb_render_scene(INTEGRATOR_PATH, DISPERSION_HERO, RES, 64);
    s->settings.media = 1;
    s->settings.maxdepth = 16;
    sb_look_at(s, vec3_make(0, 1, -6), vec3_make(0, 0, 0), 35);
    light_t env = {.kind = LIGHT_INFINITE, .spectrum = sb_constant(s, 0.3), .scale = 1.0};
    assert_true(scene_add_light(s, &env, &err) >= 0);
    light_t pt = {.kind = LIGHT_POINT, .spectrum = sb_constant(s, 1.0), .scale = 30.0, .position = vec3_make(1, 4, -1)};
    assert_true(scene_add_light(s, &pt, &err) >= 0);
    medium_params_t p = {.sigma_a = ramp(s, 0.4, 0.05), .sigma_s = ramp(s, 0.5, 2.0), .scale = 4.0, .g = 0.3,
                         .Le_scale = 1.0};
    transform_t to_world = transform_translate(vec3_make(-1.25, -1.75, -5.75));
    medium_t *m;
    if (vdb) {
        size_t len;
        uint8_t *b = read_all(CLOUD_REF, &len);
        nanovdb_grid_t *g = read_grid(b, len, "density");
        free(b);
        m = medium_new_nanovdb(&p, &g, NULL, 0.0, 1.0, &to_world, &err);
        assert_null(g);
    } else {
        double dens[12 * 12 * 12];
        for (int c = 0; c < 12; c++)
            for (int b = 0; b < 12; b++)
                for (int a = 0; a < 12; a++)
                    dens[(c * 12 + b) * 12 + a] = cloud_density(a, b, c);
        vec3_t p0 = vec3_make(-0.375, 0.125, 4.125);
        m = medium_new_grid(&p, 12, 12, 12, dens, p0, vec3_add(p0, vec3_make(3, 3, 3)), &to_world, &err);
    }
    if (!m)
        fail_msg("%s", err.msg);
    add_medium_sphere(s, 2.8, scene_add_medium(s, m, &err), -1);
    sb_finish(s);
    return s;
}

static void test_nanovdb_equals_uniformgrid(void **state)
{
    (void)state;
    scene_t *v = cloud_scene(1), *u = cloud_scene(0);
    const medium_t *mv = v->media[0], *mu = u->media[0];
    assert_int_equal(medium_kind(mv), MEDIUM_GRID);
    uint64_t x = 12345;
    double peak = 0.0;
    for (int i = 0; i < 4000; i++) {
        double c[3];
        for (int a = 0; a < 3; a++) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            c[a] = -2.0 + 4.0 * (double)(x >> 11) / 9007199254740992.0;
        }
        vec3_t p = vec3_make(c[0], c[1], c[2]);
        double dv = medium_density(mv, p), du = medium_density(mu, p);
        testutil_assert_near(dv, du, 1e-9);
        peak = fmax(peak, dv);
    }
    assert_true(peak > 0.5); /* the points reached the cloud */
    /* the 64^3 majorant cells bound the density on every segment of random rays */
    for (int r = 0; r < 200; r++) {
        double c[6];
        for (int a = 0; a < 6; a++) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            c[a] = -1.0 + 2.0 * (double)(x >> 11) / 9007199254740992.0;
        }
        vec3_t org = vec3_make(3 * c[0], 3 * c[1], -4), dir = vec3_normalize(vec3_make(c[3], c[4], 2 + c[5]));
        medium_segments_t it;
        medium_segments_begin(mv, org, dir, 20.0, &it);
        double t0, t1, dmax;
        while (medium_segments_next(&it, &t0, &t1, &dmax))
            for (int k = 0; k <= 8; k++) {
                double t = t0 + (t1 - t0) * k / 8.0;
                assert_true(medium_density(mv, vec3_fma(org, dir, t)) <= dmax * (1 + 1e-9) + 1e-12);
            }
    }
    u->settings.seed = 99;
    sb_image_stats_t a = sb_render_stats(v, RES, 128), b = sb_render_stats(u, RES, 128);
    printf("nanovdb %.5f +- %.5f, uniformgrid %.5f +- %.5f\n", a.mean, a.se, b.mean, b.se);
    double tol = 5.0 * sqrt(a.se * a.se + b.se * b.se);
    if (!(fabs(a.mean - b.mean) <= tol))
        fail_msg("nanovdb %.5f +- %.5f, uniformgrid %.5f +- %.5f", a.mean, a.se, b.mean, b.se);
    v->settings.media = 0;
    sb_image_stats_t c = sb_render_stats(v, RES, 128);
    printf("without the medium %.5f +- %.5f\n", c.mean, c.se);
    assert_true(fabs(c.mean - a.mean) > 5.0 * sqrt(a.se * a.se + c.se * c.se));
    scene_destroy(&v);
    scene_destroy(&u);
}

/* The temperature grid's emission (pbrt-v4 NanoVDBMedium::Le): Lescale times the normalised
 * blackbody of (T - offset) scale, nothing at or below 100 K. */
static void test_nanovdb_temperature(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = sb_new_scene();
    size_t len;
    uint8_t *b = read_all(CLOUD_REF, &len);
    nanovdb_grid_t *d = read_grid(b, len, "temperature"), *t = read_grid(b, len, "temperature");
    free(b);
    medium_params_t p = {.sigma_a = sb_constant(s, 1.0), .sigma_s = sb_constant(s, 1.0), .scale = 1.0, .Le_scale = 2.0};
    transform_t id = transform_identity();
    medium_t *m = medium_new_nanovdb(&p, &d, &t, 50.0, 2.0, &id, &err);
    if (!m)
        fail_msg("%s", err.msg);
    assert_true(medium_is_emissive(m) && medium_Le_varies(m));
    /* T = 1150 at x = 1.5: (1150 - 50) 2 = 2200 K */
    testutil_assert_near(medium_Le_at(m, vec3_make(1.5, 0.5, 0.5), 600.0), 2.0 * spectrum_blackbody_eval(600.0, 2200.0),
                         1e-9);
    medium_destroy(&m);
    d = NULL;
    b = read_all(CLOUD_REF, &len);
    d = read_grid(b, len, "density");
    t = read_grid(b, len, "temperature");
    free(b);
    m = medium_new_nanovdb(&p, &d, &t, 1100.0, 1.0, &id, &err); /* 50 K: too cold to glow */
    assert_non_null(m);
    testutil_assert_near(medium_Le_at(m, vec3_make(1.5, 0.5, 0.5), 600.0), 0.0, 0);
    medium_destroy(&m);
    scene_destroy(&s);
}

/* Glass focusing a large area light into fog (the volumetric caustic: L S S V E), the
 * Integrator line given by the test. */
static const char *VOLCAUSTIC =
    "LookAt 0 1.2 -6  0 1.2 0  0 1 0\n"
    "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0 0 0] \"rgb sigma_s\" [0.5 0.5 0.5]\n"
    "Camera \"perspective\" \"float fov\" [30]\n"
    "Film \"rgb\" \"integer xresolution\" [24] \"integer yresolution\" [24]\n"
    "%s\n"
    "WorldBegin\n"
    "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [10 10 10]\nTranslate 0 6 0\nRotate 90 1 0 0\n"
    "Shape \"disk\" \"float radius\" [0.8]\nAttributeEnd\n"
    "AttributeBegin\nMaterial \"dielectric\" \"float eta\" 1.5\nTranslate 0 3.3 0\n"
    "Shape \"sphere\" \"float radius\" [1]\nAttributeEnd\n"
    "AttributeBegin\nMediumInterface \"fog\" \"\"\nMaterial \"interface\"\nTranslate 0 0.9 0\n"
    "Shape \"sphere\" \"float radius\" [1.3]\nAttributeEnd\n";

static scene_t *volcaustic(const char *integrator)
{
    char text[2048];
    snprintf(text, sizeof text, VOLCAUSTIC, integrator);
    return sb_load_text(text, NULL);
}

static void axis_means(scene_t *s, const photon_store_t *ps, int spp, double *axis, double *sides);

/* Under bdpt the plan runs no photon pass here (the light is large: path tracing finds its
 * caustic), the medium is kept, and volpath's phase sampling finds the caustic: the fog on the
 * cone's axis below the ball lens (its focus at 1.5 radii below the centre) is brighter than
 * the fog beside it, which the ball shades from the light. A 24x24 film at 256 spp: on the axis
 * about 0.22, beside about 0.01 (two seeds at 512 spp); asserted above 0.08 and above 5 times
 * the sides. */
static void test_bdpt_volumetric_caustic(void **state)
{
    (void)state;
    scene_t *s = volcaustic("Integrator \"bdpt\" \"integer maxdepth\" [6]");
    assert_true(s->settings.media);
    assert_false(s->settings.photon.enabled);
    double axis, sides;
    axis_means(s, NULL, 256, &axis, &sides);
    printf("fog on the caustic's axis %.4f, beside it %.4f\n", axis, sides);
    assert_true(axis > 0.08);
    assert_true(axis > 5.0 * sides);
    scene_destroy(&s);
}

/* The same fog and ball lens under the photon integrator, which carries the medium in both
 * passes: the volumetric caustic (L S S V E) now comes from the volume photons, gathered at
 * the camera path's scattering points, and everything else from the camera pass as under
 * volpath. The fog's mean on the caustic's axis must be volpath's within 12 %. Seeds 1-5 at
 * these counts: volpath (256 spp) 0.2268 +- 0.0093, volume photons (100000 photons, the 64
 * nearest within 4 x 0.04, 64 spp) 0.2158 +- 0.0122 (means and the spread of one render), so
 * the ratio of two renders spreads by about 6 % and their means differ by 1.6 standard errors
 * (the gather sphere reaches past the fog's edge and blurs the focus: a fixed radius of 0.04
 * read 0.2207, of 0.08 5 % low). */
static void test_volume_photons_match_volpath(void **state)
{
    (void)state;
    scene_t *v = volcaustic("Integrator \"volpath\" \"integer maxdepth\" [6]");
    scene_t *p = volcaustic("Integrator \"photon\" \"integer maxdepth\" [6] \"integer photons\" [100000] "
                            "\"float radius\" [0.04]");
    assert_true(p->settings.media && p->settings.photon.enabled);
    err_t err;
    photon_store_t *ps = photon_pass_run(p, 1, NULL, NULL, &err);
    if (!ps)
        fail_msg("photon pass: %s", err.msg);
    assert_true(photon_map_count(photon_store_volume_map(ps)) > 1000);
    double va, vs, pa, pside;
    axis_means(v, NULL, 256, &va, &vs);
    axis_means(p, ps, 64, &pa, &pside);
    printf("fog on the caustic's axis: volpath %.4f, volume photons %.4f (ratio %.3f); beside it "
           "%.4f, %.4f\n",
           va, pa, pa / va, vs, pside);
    assert_true(fabs(pa / va - 1.0) < 0.12);
    assert_true(fabs(pside - vs) < 0.02 + 0.2 * vs);
    photon_store_destroy(&ps);
    scene_destroy(&p);
    scene_destroy(&v);
}

/* ---- volume photons (render/photon_volume.h, docs/physics.md §12) ---- */

static void sum_power(void *user, vec3_t dir, int bucket, double power)
{
    (void)dir;
    (void)bucket;
    *(double *)user += power;
}

/* Where a ray from the point (0, D, 0) toward the glass ball (n, radius 1, centre 0), passing
 * the ball at distance h from the axis, crosses the axis after the ball: Snell's law at both
 * surfaces (the ray optics the photon tracer is checked against). */
static double ball_focus(double D, double n, double h)
{
    const double ang = atan2(h, D); /* off the axis at the source */
    vec3_t o = vec3_make(0, D, 0), d = vec3_make(sin(ang), -cos(ang), 0);
    for (int k = 0; k < 2; k++) {
        const double b = vec3_dot(o, d), c = vec3_dot(o, o) - 1.0;
        const double t = k == 0 ? -b - sqrt(b * b - c) : -b + sqrt(b * b - c);
        o = vec3_fma(o, d, t);
        vec3_t nn = k == 0 ? o : vec3_neg(o); /* against the ray */
        const double eta = k == 0 ? 1.0 / n : n, ci = -vec3_dot(nn, d);
        const double ct = sqrt(1.0 - eta * eta * (1.0 - ci * ci));
        d = vec3_normalize(vec3_add(vec3_scale(d, eta), vec3_scale(nn, eta * ci - ct)));
    }
    return o.y - o.x / d.x * d.y; /* where x = 0 */
}

/* A spot light 8 radii above a glass ball (n = 1.5) in homogeneous fog: the volume photons'
 * density along the axis below the ball peaks at the ball's focus, where ray optics puts it:
 * between the marginal rays' crossing (the spot's edge, h = 0.3) and the paraxial focus
 * (1 / s_i = 1 / f - 1 / 8, f = n R / (2 (n - 1)) = 1.5: s_i = 1.846 below the centre), and
 * the density there is many times that 0.6 radii further down. */
static void test_volume_caustic_focus(void **state)
{
    (void)state;
    const char *text =
        "LookAt 0 0 -6  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [30]\n"
        "Film \"rgb\" \"integer xresolution\" [8] \"integer yresolution\" [8]\n"
        "Integrator \"photon\" \"integer photons\" [200000] \"float radius\" [0.04]\n"
        "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0 0 0] \"rgb sigma_s\" [0.2 0.2 0.2]\n"
        "WorldBegin\n"
        "LightSource \"spot\" \"point3 from\" [0 8 0] \"point3 to\" [0 0 0] \"float coneangle\" [2.1]"
        " \"float conedeltaangle\" [0] \"rgb I\" [100 100 100]\n"
        "AttributeBegin\nMediumInterface \"\" \"fog\"\nMaterial \"dielectric\" \"float eta\" 1.5\n"
        "Shape \"sphere\" \"float radius\" [1]\nAttributeEnd\n"
        "AttributeBegin\nMediumInterface \"fog\" \"\"\nMaterial \"interface\"\n"
        "Shape \"sphere\" \"float radius\" [20]\nAttributeEnd\n";
    scene_t *s = sb_load_text(text, NULL);
    assert_true(s->settings.media && s->settings.photon.enabled);
    err_t err;
    photon_store_t *ps = photon_pass_run(s, 1, NULL, NULL, &err);
    if (!ps)
        fail_msg("photon pass: %s", err.msg);
    assert_true(photon_store_has_volume(ps));
    assert_true(photon_map_count(photon_store_volume_map(ps)) > 1000);
    const double paraxial = ball_focus(8.0, 1.5, 1e-4), marginal = ball_focus(8.0, 1.5, 0.3);
    double best = 0.0, best_y = 0.0, dens[96];
    for (int i = 0; i < 96; i++) {
        const double y = -1.1 - 0.02 * i;
        double sum = 0.0, scale;
        /* A fixed sphere of radius 0.04 (the k-nearest estimate's own noise would move the peak). */
        photon_map_gather(photon_store_volume_map(ps), vec3_make(0, y, 0), vec3_make(0, 0, 1), 0.04,
                          0, sum_power, &sum, &scale);
        dens[i] = sum * scale;
        if (dens[i] > best) {
            best = dens[i];
            best_y = y;
        }
    }
    const int at = (int)lround((-1.1 - best_y) / 0.02);
    printf("volume caustic: density peaks at y = %.3f; ray optics: marginal %.3f, paraxial %.3f; "
           "0.6 further down %.3g of the peak\n",
           best_y, marginal, paraxial, at + 30 < 96 ? dens[at + 30] / best : 0.0);
    assert_true(paraxial < -1.84 && paraxial > -1.85);
    assert_true(best_y <= marginal + 0.04 && best_y >= paraxial - 0.04);
    assert_true(at + 30 < 96 && dens[at + 30] < 0.25 * best);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

/* The mean of the fog's pixels on the caustic's axis and beside it (rows 4-9, as
 * test_bdpt_volumetric_caustic reads them), for the scene rendered with the store ps (NULL: none). */
static void axis_means(scene_t *s, const photon_store_t *ps, int spp, double *axis, double *sides)
{
    enum { N = 24 };
    err_t err;
    const int nb = s->settings.grid.n;
    s->settings.spp = spp;
    tilebuf_t *t = tilebuf_new(0, 0, N, N, nb, &err);
    assert_non_null(t);
    render_stats_t rs = {0};
    if (render_tile(s, ps, 0, 0, N, N, 0, (uint32_t)spp, t, &rs, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(rs.nonfinite, 0);
    *axis = *sides = 0.0;
    for (int y = 4; y < 10; y++)
        for (int x = 0; x < 4; x++) {
            double px[3] = {0, 0, 0};
            const int cols[3] = {10 + x, 3 + x, 17 + x};
            for (int k = 0; k < 3; k++) {
                for (int b = 0; b < nb; b++)
                    px[k] += tilebuf_sum(t, cols[k], y, b);
                px[k] /= (double)nb * (double)tilebuf_count(t, cols[k], y);
            }
            *axis += px[0] / 24.0;
            *sides += (px[1] + px[2]) / 48.0;
        }
    tilebuf_destroy(&t);
}

/* ---- the surface store seen through fog (render/render.c, docs/physics.md §12) ---- */

/* A grey diffuse patch lit only through a glass slab by a distant light (its light is L S S D,
 * the surface store's alone: the shadow ray stops at glass), and a fog ball beside it that the
 * slab's beam misses (a black card shades it), seen by a camera that also sees the patch. The
 * fog's light from the patch is L S S D V+ E: the camera path meets the patch after scattering
 * in the fog. The same scene with the patch an area light of radiance L and no distant light
 * (volpath, one bounce shorter, as an emitter ends a path that a reflector continues) gives
 * the fog's light from a Lambertian patch of that radiance, so the fog over the patch must
 * read the same in both. The fog's box at PATCH_FOG_SPP (the patch's at an eighth of it):
 * the ratio of the two ratios is 0.961 here; the CLI's 32x32 renders of the two scenes, two
 * seeds each at 512 and 1024 spp with 200000 photons, read 0.0133 and 0.0140 against 0.0133
 * and 0.0135, so its spread is a few per cent; PATCH_FOG_TOL is 10 %. Release 0.24 CPU s,
 * ASan 0.47. */
#define PATCH_FOG_SPP 512
#define PATCH_FOG_TOL 0.1
static const char *PATCH_FOG =
    "LookAt 1.1 1.3 -4.5  1.1 0.4 0  0 1 0\n"
    "Camera \"perspective\" \"float fov\" [42]\n"
    "Film \"rgb\" \"integer xresolution\" [32] \"integer yresolution\" [32]\n"
    "%s\n"
    "WorldBegin\n"
    "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0 0 0] \"rgb "
    "sigma_s\" [2 2 2]\n"
    "%s\n"
    "AttributeBegin\nMaterial \"dielectric\" \"float eta\" 1.5\n"
    "Shape \"trianglemesh\" \"point3 P\" [-1.3 2 -1.3  1.3 2 -1.3  1.3 2 1.3  -1.3 2 1.3] "
    "\"integer indices\" [0 2 1 0 3 2]\n"
    "Shape \"trianglemesh\" \"point3 P\" [-1.3 1.9 -1.3  1.3 1.9 -1.3  1.3 1.9 1.3  -1.3 1.9 1.3] "
    "\"integer indices\" [0 1 2 0 2 3]\nAttributeEnd\n"
    "AttributeBegin\nMaterial \"diffuse\" \"rgb reflectance\" [0 0 0]\n"
    "Shape \"trianglemesh\" \"point3 P\" [1.6 1.5 -0.7  2.8 1.5 -0.7  2.8 1.5 0.7  1.6 1.5 0.7] "
    "\"integer indices\" [0 1 2 0 2 3]\nAttributeEnd\n"
    "AttributeBegin\n%s\n"
    "Shape \"trianglemesh\" \"point3 P\" [-1 0 -1  1 0 -1  1 0 1  -1 0 1] \"integer indices\" [0 2 "
    "1 0 3 2]\n"
    "AttributeEnd\n"
    "AttributeBegin\nMediumInterface \"fog\" \"\"\nMaterial \"interface\"\nTranslate 2.2 0.5 0\n"
    "Shape \"sphere\" \"float radius\" [0.45]\nAttributeEnd\n";

/* The mean over the buckets and the pixels of the w x h box at (x0, y0) of scene s's 32x32
 * image, rendered with the store ps (NULL: none) at spp samples. */
static double box_mean(const scene_t *s, const photon_store_t *ps, int spp, int x0, int y0, int w,
                       int h)
{
    err_t err;
    const int nb = s->settings.grid.n;
    tilebuf_t *t = tilebuf_new(x0, y0, w, h, nb, &err);
    assert_non_null(t);
    render_stats_t rs = {0};
    if (render_tile(s, ps, x0, y0, w, h, 0, (uint32_t)spp, t, &rs, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(rs.nonfinite, 0);
    double sum = 0.0;
    for (int y = y0; y < y0 + h; y++)
        for (int x = x0; x < x0 + w; x++) {
            double px = 0.0;
            for (int b = 0; b < nb; b++)
                px += tilebuf_sum(t, x, y, b);
            sum += px / ((double)nb * (double)tilebuf_count(t, x, y));
        }
    tilebuf_destroy(&t);
    return sum / (double)(w * h);
}

/* The patch's own radiance (seen straight: columns 2-12, rows 18-21) and the fog ball's
 * (columns 23-27, rows 12-16). */
static void patch_and_fog(const scene_t *s, const photon_store_t *ps, double *patch, double *fog)
{
    *patch = box_mean(s, ps, PATCH_FOG_SPP / 8, 2, 18, 11, 4);
    *fog = box_mean(s, ps, PATCH_FOG_SPP, 23, 12, 5, 5);
}

/* Before the surface store was gathered at every diffuse vertex (it was gathered only at the
 * first, and only where no scattering came before), the lit patch's light in the fog was path
 * traced from the patch, which cannot find a distant light through glass: the fog read 0 here;
 * in Bitterli's volumetric-caustic the same paths, from a 5 mm light, were a heavy tail that
 * left the red wall and floor 12 % dark at 64 spp (docs/compatibility.md). */
static void test_surface_caustic_through_fog(void **state)
{
    (void)state;
    char text[4096];
    snprintf(
        text, sizeof text, PATCH_FOG,
        "Integrator \"photon\" \"integer maxdepth\" [3] \"integer photons\" [60000] "
        "\"float radius\" [0.04]",
        "LightSource \"distant\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0] \"rgb L\" [1 1 1]",
        "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]");
    scene_t *a = sb_load_text(text, NULL);
    snprintf(text, sizeof text, PATCH_FOG, "Integrator \"volpath\" \"integer maxdepth\" [2]", "",
             "AreaLightSource \"diffuse\" \"rgb L\" [0.15 0.15 0.15]\n"
             "Material \"diffuse\" \"rgb reflectance\" [0 0 0]");
    scene_t *b = sb_load_text(text, NULL);
    assert_true(a->settings.media && a->settings.photon.enabled);
    assert_true(b->settings.media && !b->settings.photon.enabled);
    err_t err;
    photon_store_t *ps = photon_pass_run(a, 1, NULL, NULL, &err);
    if (!ps)
        fail_msg("photon pass: %s", err.msg);
    double pa, fa, pb, fb;
    patch_and_fog(a, ps, &pa, &fa);
    patch_and_fog(b, NULL, &pb, &fb);
    printf("patch %.4f and fog %.4f (ratio %.4f) lit through glass; patch %.4f and fog %.4f "
           "(ratio %.4f) emitting: %.3f\n",
           pa, fa, fa / pa, pb, fb, fb / pb, (fa / pa) / (fb / pb));
    assert_true(pa > 0.0 && pb > 0.0 && fb > 0.0);
    assert_true(fabs((fa / pa) / (fb / pb) - 1.0) < PATCH_FOG_TOL);
    photon_store_destroy(&ps);
    scene_destroy(&b);
    scene_destroy(&a);
}

/* ---- the scene format ---- */

/* ---- equiangular sampling (sampling/equiangular.h, render.c; docs/physics.md §12) ---- */

/* The sampler against its density: a histogram of 200000 draws over 20 equal bins of the
 * segment (the unbounded one's rest a 21st) against the density's integral over each bin
 * (chi-square, about 19 degrees of freedom, asserted below 60: p < 1e-5 by chance), for a light
 * point beside the segment, one on the ray inside it, one at its origin, one far beyond its end
 * and an unbounded segment. A bin's probability is the closed form (atan((z - delta) / D) -
 * atan((a - delta) / D)) / dtheta; where the density is wide enough to integrate numerically
 * (beside, far beyond) Simpson's rule over the segment checks that it integrates to 1. Every
 * sample lies in [0, tmax) with a finite positive density, also where D is the floor. */
static double eq_cdf_between(const equiangular_t *e, double a, double z)
{
    const double ta = atan((a - e->delta) / e->D), tz = isfinite(z) ? atan((z - e->delta) / e->D) : PF_PI / 2;
    return (tz - ta) / e->dtheta;
}

static void test_equiangular_sampler(void **state)
{
    (void)state;
    const vec3_t o = vec3_make(0, 0, 0), d = vec3_make(0, 0, 1);
    const struct {
        vec3_t c;
        double tmax;
        int simpson;
        const char *what;
    } cases[] = {
        {{0.05, 0.0, 1.2}, 3.0, 1, "beside"},
        {{0.0, 0.0, 1.2}, 3.0, 0, "on the ray"},
        {{0.0, 0.0, 0.0}, 3.0, 0, "at the origin"},
        {{0.3, 0.2, 1e3}, 3.0, 1, "far beyond"},
        {{0.0, 0.3, 2.0}, INFINITY, 0, "unbounded"},
    };
    rng_stream_t rng = rng_stream_make(11, 0, 0);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        equiangular_t e;
        assert_true(equiangular_make(o, d, cases[c].tmax, cases[c].c, &e));
        enum { NB = 20, N = 200000 };
        const double L = isfinite(cases[c].tmax) ? cases[c].tmax : 10.0;
        int count[NB + 1] = {0};
        for (int i = 0; i < N; i++) {
            double t = equiangular_sample(&e, rng_stream_next(&rng));
            assert_true(t >= 0.0 && t < cases[c].tmax);
            double pdf = equiangular_pdf(&e, t);
            assert_true(pdf > 0.0 && isfinite(pdf));
            int b = (int)(t / L * NB);
            count[b < NB ? b : NB]++;
        }
        double chi2 = 0.0;
        for (int b = 0; b <= NB; b++) {
            double a = b * L / NB, z = b < NB ? (b + 1) * L / NB : cases[c].tmax;
            if (!(z > a))
                continue;
            double expect = eq_cdf_between(&e, a, z) * N;
            if (expect > 5.0)
                chi2 += (count[b] - expect) * (count[b] - expect) / expect;
        }
        double total = 1.0;
        if (cases[c].simpson) {
            const int K = 200000;
            total = 0.0;
            for (int k = 0; k <= K; k++) {
                double t = fmin(L * k / K, nextafter(L, 0.0));
                total += ((k == 0 || k == K) ? 1 : (k % 2 ? 4 : 2)) * equiangular_pdf(&e, t);
            }
            total *= L / K / 3.0;
        }
        printf("equiangular %s: chi2 %.1f, integral %.9f\n", cases[c].what, chi2, total);
        assert_true(fabs(total - 1.0) < 1e-6);
        assert_true(chi2 < 60.0);
    }
    /* Outside the segment: 0; no length: unusable. */
    equiangular_t e;
    assert_true(equiangular_make(o, d, 3.0, vec3_make(0, 1, 1), &e));
    assert_true(equiangular_pdf(&e, -1e-9) == 0.0 && equiangular_pdf(&e, 3.0) == 0.0);
    assert_false(equiangular_make(o, d, 0.0, vec3_make(0, 1, 1), &e));
}

/* Single scattering of a light point L beside a camera ray in an unbounded homogeneous fog
 * (sigma_a 0.1, sigma_s 0.5, g 0.3), the ray from the origin along +z and the point at height
 * EQ_H over it, EQ_Z along it: the radiance the ray sees after one scattering,
 *
 *     L = int_0^inf sigma_s e^{-sigma_t t} p(cos) I e^{-sigma_t d} / d^2 dt,
 *
 * d the distance from the ray's point to the light and cos = (t - z) / d (pbrt-v4's HG
 * convention, both directions away from the point), integrated numerically with
 * t = z + D tan(theta) (D the point's distance from the ray), which makes the integrand smooth:
 * Simpson on 20000 intervals of theta. For an area light the integrand has the light's cosine
 * |y| / d too, and a 6x6 Gauss-Legendre rule over the quad. */
#define EQ_SA 0.1
#define EQ_SS 0.5
#define EQ_G 0.3
#define EQ_H 0.1
#define EQ_Z 1.5
#define EQ_SIDE 0.02
#define EQ_RES 32
#define EQ_SPP 32
#define EQ_AREA_L 1000.0

static double hg_ref(double cos_t, double g)
{
    return (1.0 - g * g) / (4.0 * PF_PI * pow(1.0 + g * g + 2.0 * g * cos_t, 1.5));
}

static double single_scatter_ref(double xl, double yl, double zl, int area)
{
    const double st = EQ_SA + EQ_SS, D = sqrt(xl * xl + yl * yl);
    const double th0 = atan(-zl / D), th1 = atan((80.0 - zl) / D);
    const int K = 20000;
    double sum = 0.0;
    for (int k = 0; k <= K; k++) {
        double th = th0 + (th1 - th0) * k / K, t = zl + D * tan(th);
        double d = D / cos(th);
        double f = EQ_SS * exp(-st * t) * hg_ref((t - zl) / d, EQ_G) * exp(-st * d) / D;
        if (area)
            f *= fabs(yl) / d;
        sum += ((k == 0 || k == K) ? 1 : (k % 2 ? 4 : 2)) * f;
    }
    return sum * (th1 - th0) / K / 3.0;
}

static double area_ref(void)
{
    static const double x[6] = {-0.9324695142, -0.6612093865, -0.2386191861,
                                0.2386191861,  0.6612093865,  0.9324695142};
    static const double w[6] = {0.1713244924, 0.3607615730, 0.4679139346,
                                0.4679139346, 0.3607615730, 0.1713244924};
    const double h = EQ_SIDE / 2.0;
    double sum = 0.0;
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < 6; j++)
            sum += w[i] * w[j] * h * h * single_scatter_ref(h * x[i], EQ_H, EQ_Z + h * x[j], 1);
    return sum;
}

/* The scene: the camera at the origin in the fog looking along +z with a field of view of
 * 0.05 degrees (every pixel sees the same ray to 1e-5 of the integrand), maxdepth 1 (single
 * scattering only), constant spectra (every bucket estimates L), lit by a point light of
 * intensity 1 or a two-sided square of radiance EQ_AREA_L and side EQ_SIDE facing the ray. Returns the
 * image mean over the buckets and pixels, its standard error from the pixels' spread, and the
 * variance of one pixel's estimate. */
static void eq_render(int area, medium_sampling_kind_t ms, double *mean, double *se, double *var)
{
    err_t err;
    scene_t *s = sb_render_scene(INTEGRATOR_PATH, DISPERSION_HERO, EQ_RES, EQ_SPP);
    s->settings.media = 1;
    s->settings.maxdepth = 1;
    s->settings.medium_sampling = ms;
    sb_look_at(s, vec3_make(0, 0, 0), vec3_make(0, 0, 1), 0.05);
    s->camera_medium = add_homogeneous(s, sb_constant(s, EQ_SA), sb_constant(s, EQ_SS), 1.0, EQ_G);
    /* The fog's bounds for the scene's size (a light is "small" beside it, render.c
     * eq_light_ok): a pass-through sphere of radius 30, fog on both sides (its light is
     * e^-18 of the ray's). */
    add_medium_sphere(s, 30.0, s->camera_medium, s->camera_medium);
    if (area) {
        light_t l = {.kind = LIGHT_AREA, .spectrum = sb_constant(s, 1.0), .scale = EQ_AREA_L, .twosided = 1};
        int li = scene_add_light(s, &l, &err);
        assert_true(li >= 0);
        const double h = EQ_SIDE / 2.0;
        const double P[12] = {-h, EQ_H, EQ_Z - h, h, EQ_H, EQ_Z - h, h, EQ_H, EQ_Z + h, -h, EQ_H, EQ_Z + h};
        const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
        assert_true(scene_add_mesh(s, P, 4, idx, 2, NULL, NULL, sb_diffuse(s, 0.0), li, 0, &err) >= 0);
    } else {
        light_t l = {.kind = LIGHT_POINT, .spectrum = sb_constant(s, 1.0), .scale = 1.0,
                     .position = vec3_make(0, EQ_H, EQ_Z)};
        assert_true(scene_add_light(s, &l, &err) >= 0);
    }
    sb_finish(s);
    const int nb = s->settings.grid.n;
    tilebuf_t *t = tilebuf_new(0, 0, EQ_RES, EQ_RES, nb, &err);
    assert_non_null(t);
    render_stats_t rs = {0};
    if (render_tile(s, NULL, 0, 0, EQ_RES, EQ_RES, 0, EQ_SPP, t, &rs, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(rs.nonfinite, 0);
    double sum = 0.0, sq = 0.0;
    for (int y = 0; y < EQ_RES; y++)
        for (int x = 0; x < EQ_RES; x++) {
            double px = 0.0;
            for (int b = 0; b < nb; b++)
                px += tilebuf_sum(t, x, y, b);
            px /= (double)nb * (double)tilebuf_count(t, x, y);
            sum += px;
            sq += px * px;
        }
    const int n = EQ_RES * EQ_RES;
    *mean = sum / n;
    *var = fmax(0.0, sq / n - *mean * *mean) * n / (n - 1);
    *se = sqrt(*var / n);
    tilebuf_destroy(&t);
    scene_destroy(&s);
}

/* Both samplings agree with the reference within 4 standard errors (plus 0.5 % for the
 * reference's own rule and the pixels' spread of rays), and equiangular sampling with MIS
 * has a pixel variance at least EQ_GAIN times lower than free flight's. Measured at these
 * counts: see the printout (docs/physics.md §12). A wrong MIS weight fails here: free flight's
 * next-event estimate left unweighted (weight 1) reads about twice the reference. */
#define EQ_GAIN 8.0
static void test_equiangular_single_scatter(void **state)
{
    (void)state;
    for (int area = 0; area <= 1; area++) {
        const double ref = area ? EQ_AREA_L * area_ref() : single_scatter_ref(0, EQ_H, EQ_Z, 0);
        double m[2], se[2], var[2];
        eq_render(area, MEDIUM_SAMPLING_FREEFLIGHT, &m[0], &se[0], &var[0]);
        eq_render(area, MEDIUM_SAMPLING_EQUIANGULAR, &m[1], &se[1], &var[1]);
        printf("%s light: reference %.6f; free flight %.6f +- %.6f (pixel variance %.3g); "
               "equiangular+MIS %.6f +- %.6f (pixel variance %.3g): %.1f times lower\n",
               area ? "area" : "point", ref, m[0], se[0], var[0], m[1], se[1], var[1],
               var[0] / var[1]);
        for (int k = 0; k < 2; k++)
            assert_true(fabs(m[k] - ref) <= 4.0 * se[k] + 0.005 * ref);
        assert_true(var[0] > EQ_GAIN * var[1]);
    }
}

static const char *FOGGY =
    "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0.1 0.2 0.3]\n"
    "  \"rgb sigma_s\" [1 1 1] \"float scale\" 2 \"float g\" 0.5\n"
    "MediumInterface \"\" \"fog\"\n"
    "Camera \"perspective\"\n"
    "Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\n"
    "%s"
    "WorldBegin\n"
    "LightSource \"point\" \"rgb I\" [1 1 1]\n"
    "MakeNamedMedium \"milk\" \"string type\" \"homogeneous\" \"string preset\" \"Skin1\"\n"
    "Translate 1 0 0\n"
    "MakeNamedMedium \"smoke\" \"string type\" \"uniformgrid\" \"integer nx\" 2 \"integer ny\" 1\n"
    "  \"integer nz\" 1 \"float density\" [0 4] \"point3 p0\" [-1 -1 -1] \"point3 p1\" [1 1 1]\n"
    "MakeNamedMedium \"vdb\" \"string type\" \"cloud\"\n"
    "AttributeBegin\n"
    "  MediumInterface \"milk\" \"fog\"\n"
    "  Material \"interface\"\n"
    "  Shape \"sphere\"\n"
    "AttributeEnd\n"
    "Material \"\"\n"
    "MediumInterface \"smoke\"\n"
    "Shape \"sphere\" \"float radius\" 2\n"
    "MediumInterface \"vdb\" \"\"\n"
    "Shape \"sphere\" \"float radius\" 3\n";

static scene_t *foggy(const char *integrator)
{
    char text[4096];
    snprintf(text, sizeof text, FOGGY, integrator);
    return sb_load_text(text, NULL);
}

static int has_warning(const scene_t *s, const char *needle)
{
    for (size_t i = 0; i < warnings_count(s->warnings); i++)
        if (strstr(warnings_at(s->warnings, i), needle))
            return 1;
    return 0;
}

static void test_scene_format(void **state)
{
    (void)state;
    char text[4096];
    snprintf(text, sizeof text, FOGGY, "Integrator \"volpath\"\n");
    err_t err;
    scene_desc_t *d = pbrt_parse_string(text, strlen(text), "t.pbrt", &err);
    if (!d)
        fail_msg("%s", err.msg);
    assert_int_equal(d->nmedia, 4);
    assert_int_equal(d->camera.medium, 0);
    const scene_medium_t *fog = &d->media[0], *milk = &d->media[1], *smoke = &d->media[2];
    assert_int_equal(fog->type, SCENE_MEDIUM_HOMOGENEOUS);
    testutil_assert_near(fog->scale, 2.0, 0);
    testutil_assert_near(fog->g, 0.5, 0);
    testutil_assert_near(fog->sigma_a.rgb[2], 0.3, 0);
    /* pbrt-v4's table: Skin1 is sigma'_s (0.74, 0.88, 1.01), sigma_a (0.032, 0.17, 0.48) */
    assert_int_equal(milk->sigma_s.kind, SCENE_SPECTRUM_RGB);
    testutil_assert_near(milk->sigma_s.rgb[1], 0.88, 0);
    testutil_assert_near(milk->sigma_a.rgb[2], 0.48, 0);
    assert_int_equal(smoke->type, SCENE_MEDIUM_GRID);
    assert_int_equal(smoke->nx, 2);
    testutil_assert_near(smoke->density[1], 4.0, 0);
    testutil_assert_near(smoke->to_world.m[0][3], 1.0, 0); /* the CTM at MakeNamedMedium */
    assert_int_equal(d->media[3].type, SCENE_MEDIUM_IGNORED);
    assert_int_equal(d->shapes[0].inside_medium, 1);
    assert_int_equal(d->shapes[0].outside_medium, 0);
    /* AttributeEnd restored the outer interface; one name means both sides */
    assert_int_equal(d->shapes[1].inside_medium, 2);
    assert_int_equal(d->shapes[1].outside_medium, 2);
    assert_string_equal(d->materials[d->shapes[1].material].type, ""); /* interface */
    scene_desc_destroy(&d);

    scene_t *s = foggy("Integrator \"volpath\"\n");
    assert_true(s->settings.media);
    assert_int_equal(s->nmedia, 4);
    assert_int_equal(s->camera_medium, 0);
    assert_null(s->media[3]); /* cloud: vacuum */
    assert_int_equal(s->shapes[2].medium_inside, -1);
    assert_true(has_warning(s, "\"cloud\" media are not simulated"));
    assert_false(has_warning(s, "ignored"));
    medium_coeffs_t c = medium_coeffs(s->media[0], 550.0);
    assert_true(c.sigma_s > 1.9 && c.sigma_s < 2.1); /* rgb 1 1 1 times scale 2 */
    scene_destroy(&s);
    /* No Integrator: pbrt-v4's default volpath renders media, and so does "auto". */
    s = foggy("");
    assert_true(s->settings.media);
    scene_destroy(&s);
    /* pbrt-v4's path ignores media, and so does prismfarm's, saying so */
    s = foggy("Integrator \"path\"\n");
    assert_false(s->settings.media);
    assert_true(has_warning(s, "pbrt-v4's \"path\" integrator ignores media too"));
    scene_destroy(&s);
    /* The photon integrator carries media in both passes (render/photon_volume.h). */
    s = foggy("Integrator \"photon\"\n");
    assert_true(s->settings.media);
    assert_false(has_warning(s, "ignored"));
    scene_destroy(&s);
    /* "string mediumsampling": equiangular by default (volpath, bdpt), freeflight asked for. */
    s = foggy("Integrator \"bdpt\"\n");
    assert_int_equal(s->settings.medium_sampling, MEDIUM_SAMPLING_EQUIANGULAR);
    scene_destroy(&s);
    s = foggy("Integrator \"volpath\" \"string mediumsampling\" \"freeflight\"\n");
    assert_int_equal(s->settings.medium_sampling, MEDIUM_SAMPLING_FREEFLIGHT);
    scene_destroy(&s);
    snprintf(text, sizeof text, FOGGY, "Integrator \"volpath\" \"string mediumsampling\" \"beams\"\n");
    assert_null(sb_load_text(text, &err));
    assert_non_null(strstr(err.msg, "unsupported \"string mediumsampling\""));

    struct {
        const char *text, *msg;
    } bad[] = {
        {"WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"jelly\"\n", "unknown medium type \"jelly\""},
        {"WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"uniformgrid\" \"integer nx\" 2 \"float density\" [1]\n",
         "1 \"density\" values, expected nx*ny*nz = 2*1*1"},
        {"WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"uniformgrid\" \"float density\" [-1]\n",
         "\"density\" value 0 is -1"},
        {"WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"uniformgrid\"\n", "needs \"float density\""},
        {"WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"homogeneous\" \"float g\" 1\n", "\"float g\" must be in (-1, 1)"},
        {"WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"homogeneous\" \"float bogus\" 1\n", "unsupported parameter \"float bogus\""},
        {"WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"homogeneous\"\nMakeNamedMedium \"a\" \"string type\" \"homogeneous\"\n",
         "medium \"a\" is already defined"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        scene_desc_t *b = pbrt_parse_string(bad[i].text, strlen(bad[i].text), "t.pbrt", &err);
        if (b)
            fail_msg("accepted: %s", bad[i].text);
        if (!strstr(err.msg, bad[i].msg))
            fail_msg("\"%s\" does not say \"%s\"", err.msg, bad[i].msg);
    }
    /* A temperature grid and an unknown preset are accepted with warnings. */
    const char *warm = "WorldBegin\nMakeNamedMedium \"a\" \"string type\" \"uniformgrid\" \"float density\" [1]\n"
                       "  \"float temperature\" [1000]\n"
                       "MakeNamedMedium \"b\" \"string type\" \"homogeneous\" \"string preset\" \"Jelly\"\n";
    d = pbrt_parse_string(warm, strlen(warm), "t.pbrt", &err);
    if (!d)
        fail_msg("%s", err.msg);
    assert_int_equal(warnings_count(d->warnings), 2);
    assert_non_null(strstr(warnings_at(d->warnings, 0), "\"temperature\" grid of medium \"a\" is not simulated"));
    assert_non_null(strstr(warnings_at(d->warnings, 1), "medium preset \"Jelly\" is not known"));
    scene_desc_destroy(&d);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hg_normalised),
        cmocka_unit_test(test_hg_sampling_chi2),
        cmocka_unit_test(test_beer_lambert_slab),
        cmocka_unit_test(test_homogeneous_flight),
        cmocka_unit_test(test_grid_tracking),
        cmocka_unit_test(test_white_furnace),
        cmocka_unit_test(test_emission),
        cmocka_unit_test(test_grid_equals_homogeneous),
        cmocka_unit_test(test_extremes_finite),
        cmocka_unit_test(test_nanovdb_reference),
        cmocka_unit_test(test_nanovdb_damaged),
        cmocka_unit_test(test_nanovdb_equals_uniformgrid),
        cmocka_unit_test(test_nanovdb_temperature),
        cmocka_unit_test(test_bdpt_volumetric_caustic),
        cmocka_unit_test(test_volume_caustic_focus),
        cmocka_unit_test(test_volume_photons_match_volpath),
        cmocka_unit_test(test_surface_caustic_through_fog),
        cmocka_unit_test(test_equiangular_sampler),
        cmocka_unit_test(test_equiangular_single_scatter),
        cmocka_unit_test(test_scene_format),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
