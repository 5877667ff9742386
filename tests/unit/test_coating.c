/* coating: a thin-film coating on smooth glass and mirrors (material_t.film_thickness,
 * bsdf/delta.h) against optics: the coated interface reflects what the Airy formula says and
 * transmits the rest, from either side; a coated glass sphere vanishes in a furnace (a lossless
 * film neither absorbs nor makes light) for every integrator and both dispersion strategies, as
 * does a coated perfect mirror; the coating's interference shows as colour, and without a
 * coating (the default) nothing changes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>
#include <string.h>

#include "delta.h"
#include "glass.h"
#include "numeric_testutil.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"
#include "thinfilm.h"

#define PI 3.14159265358979323846
static const int RES = 8;

/* The coated event against the Airy formula (polar/thinfilm.h) and R + T = 1, entering and
 * leaving, per lane; the lanes' mean reflectance chooses, each lane weighed by its own. */
static void test_coated_event(void **state)
{
    (void)state;
    const ior_model_t mgf2 = ior_constant(1.38);
    const delta_film_t film = {120.0, &mgf2};
    const double lam[4] = {420.0, 500.0, 580.0, 660.0}, n[4] = {1.52, 1.52, 1.52, 1.52};
    for (double deg = 0.0; deg < 85.0; deg += 5.0) {
        const double th = deg * PI / 180.0;
        for (int side = 0; side < 2; side++) {
            const bool entering = side == 0;
            vec3_t d = vec3_make(sin(th), 0.0, entering ? -cos(th) : cos(th));
            delta_dielectric_t e;
            delta_dielectric_make(d, vec3_make(0, 0, 1), entering, n, 4, BSDF_IMPORTANCE, &e);
            delta_dielectric_coat(&e, d, vec3_make(0, 0, 1), entering, n, lam, &film);
            double sum = 0.0;
            for (int j = 0; j < 4; j++) {
                thinfilm_t f = entering ? thinfilm_eval(cos(th), 1.0, 1.38, 120.0, 1.52, lam[j])
                                        : thinfilm_eval(cos(th), 1.52, 1.38, 120.0, 1.0, lam[j]);
                testutil_assert_near(e.reflectance[j], 0.5 * (f.Rs + f.Rp), 1e-15);
                testutil_assert_near(e.reflectance[j] + e.transmittance[j], 1.0, 0.0);
                if (e.refracts)
                    testutil_assert_near(e.transmittance[j], 0.5 * (f.Ts + f.Tp), 1e-12);
                sum += e.reflectance[j];
            }
            if (e.refracts) {
                testutil_assert_near(e.prob_reflect, sum / 4.0, 1e-15);
                for (int j = 0; j < 4; j++) {
                    double P = e.prob_reflect;
                    testutil_assert_near(
                        P * delta_dielectric_reflect_lane(&e, j, true) +
                            (1.0 - P) * delta_dielectric_transmit_lane(&e, j, 1.0 / (1.0 - P)),
                        1.0, 1e-14);
                }
            } else {
                assert_true(e.prob_reflect == 1.0);
            }
        }
    }
    /* The interference is real colour: a 120 nm MgF2 film on glass reflects blue and red
     * differently (a quarter wave at 662 nm). */
    delta_dielectric_t e;
    vec3_t down = vec3_make(0, 0, -1);
    delta_dielectric_make(down, vec3_make(0, 0, 1), true, n, 4, BSDF_RADIANCE, &e);
    delta_dielectric_coat(&e, down, vec3_make(0, 0, 1), true, n, lam, &film);
    assert_true(e.reflectance[0] > 2.0 * e.reflectance[3]);
}

typedef sb_bucket_stats_t stats_t;

/* The whole image in one tile (scene_builders.h). */
static stats_t render_stats(scene_t *s)
{
    return sb_render_bucket_stats(s, RES);
}

/* A uniform environment of radiance 1 and a coated sphere (glass of index 1.5 or a catalogue
 * glass, or a perfect mirror) filling the view: every bucket must be 1 within noise (4
 * standard errors; Whitted is deterministic and exact up to the light left inside after 64
 * bounces). */
static void furnace_at(integrator_kind_t integ, dispersion_kind_t disp, material_kind_t kind,
                       const char *glass_name, double film_n, double thickness, double expect,
                       int inside)
{
    err_t err;
    scene_t *s = sb_render_scene(integ, disp, RES, 64);
    if (inside)
        sb_look_at(s, vec3_make(0, 0, -0.2), vec3_make(0, 0, 1), 60);
    else
        sb_look_at(s, vec3_make(0, 0, -5), vec3_make(0, 0, 0), 20);
    spectrum_t *env = spectrum_new_constant(1.0, &err);
    assert_non_null(env);
    light_t l = {.kind = LIGHT_INFINITE, .spectrum = env, .scale = 1.0};
    assert_int_equal(scene_own_spectrum(s, env, &err), 0);
    assert_true(scene_add_light(s, &l, &err) >= 0);
    material_t m = {.kind = kind, .film_thickness = thickness, .film_ior = ior_constant(film_n)};
    m.ior = glass_name ? glass_find(glass_name)->ior : ior_constant(1.5);
    strcpy(m.name, "coated");
    int mi = scene_add_material(s, &m, &err);
    transform_t id = transform_identity();
    assert_true(scene_add_sphere(s, &id, 1.0, mi, -1, 0, &err) >= 0);
    if (scene_finish(s, &err))
        fail_msg("%s", err.msg);
    stats_t st = render_stats(s);
    assert_int_equal(st.nonfinite, 0);
    for (int b = 0; b < s->settings.grid.n; b++) {
        double tol = 4.0 * st.se[b] + 1e-6;
        if (!(fabs(st.mean[b] - expect) <= tol))
            fail_msg(
                "%s %s: bucket %d is %.6f +- %.6f, expected %g", glass_name ? glass_name : "n=1.5",
                kind == MATERIAL_CONDUCTOR ? "mirror" : "glass", b, st.mean[b], st.se[b], expect);
    }
    scene_destroy(&s);
}

static void furnace(integrator_kind_t integ, dispersion_kind_t disp, material_kind_t kind,
                    const char *glass_name, double film_n, double thickness)
{
    furnace_at(integ, disp, kind, glass_name, film_n, thickness, 1.0, 0);
}

/* Seen from inside glass of index n, a uniform environment of radiance 1 looks like n^2
 * (radiance concentrates into the denser medium, docs/physics.md §3.4), coated or not. */
static void test_inside(void **state)
{
    (void)state;
    furnace_at(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, NULL, 2.4, 310.0, 2.25, 1);
    furnace_at(INTEGRATOR_WHITTED, DISPERSION_HERO, MATERIAL_DIELECTRIC, NULL, 1.38, 120.0, 2.25,
               1);
}

static void test_furnace_path_hero(void **state)
{
    (void)state;
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, NULL, 2.4, 310.0);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, "N-SF11", 1.38, 120.0);
}

static void test_furnace_fanout(void **state)
{
    (void)state;
    furnace(INTEGRATOR_PATH, DISPERSION_FANOUT, MATERIAL_DIELECTRIC, "N-SF11", 1.38, 120.0);
    furnace(INTEGRATOR_SIMPLEPATH, DISPERSION_FANOUT, MATERIAL_DIELECTRIC, NULL, 2.4, 310.0);
}

static void test_furnace_whitted(void **state)
{
    (void)state;
    furnace(INTEGRATOR_WHITTED, DISPERSION_HERO, MATERIAL_DIELECTRIC, "N-BK7", 2.4, 310.0);
    furnace(INTEGRATOR_WHITTED, DISPERSION_FANOUT, MATERIAL_DIELECTRIC, NULL, 1.38, 120.0);
}

/* A lossless film over a perfect mirror (eta 0, k 1: no reflectance, no index) reflects all. */
static void test_furnace_mirror(void **state)
{
    (void)state;
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_CONDUCTOR, NULL, 1.38, 250.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_coated_event),   cmocka_unit_test(test_furnace_path_hero),
        cmocka_unit_test(test_furnace_fanout), cmocka_unit_test(test_furnace_whitted),
        cmocka_unit_test(test_furnace_mirror), cmocka_unit_test(test_inside),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
