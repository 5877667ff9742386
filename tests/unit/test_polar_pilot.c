/* polar_pilot: the plan's measurement of what ignoring polarisation changes, against optics: a
 * glass slab at 60 degrees in front of a lamp changes by (T_s + T_p)/2 over (1 - R)/(1 + R)
 * (Fresnel's inter-reflections summed per polarisation against unpolarised: 1.42 %), which is
 * over the target, so the pilot advises polarisation (it never switches it on: its figure may
 * differ between builds and CPUs) and the file's Integrator "bool polarized" true carries it;
 * a single rough metal (one interface: unpolarised
 * light reflected once is recorded the same) changes nothing and leaves it off; a scene with no
 * glass or metal runs no pilot; and the measurement is deterministic. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>
#include <stdio.h>

#include "polar_pilot.h"
#include "scene.h"
#include "scene_builders.h"

#define PI 3.14159265358979323846

/* An orthographic camera on +z, a two-sided lamp filling the view at z = -3, and `between`;
 * the integrator's parameters end with `options`. */
static scene_t *lamp_scene_with(const char *options, const char *between)
{
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 0 5  0 0 0  0 1 0\n"
             "Camera \"orthographic\" \"float screenwindow\" [-0.05 0.05 -0.05 0.05]\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
             "Integrator \"whitted\" \"integer maxdepth\" [24] %s\n"
             "WorldBegin\n"
             "AttributeBegin\n"
             "AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true\n"
             "Translate 0 0 -3\nScale 0.5 0.5 1\n" PBRT_QUAD "AttributeEnd\n%s",
             options, between);
    return sb_load_text(text, NULL);
}

static scene_t *lamp_scene(const char *between)
{
    return lamp_scene_with("", between);
}

static void test_slab(void **state)
{
    (void)state;
    const double n = 1.5, th = 60.0 * PI / 180.0, ct = sqrt(1.0 - pow(sin(th) / n, 2.0));
    const double rs = (cos(th) - n * ct) / (cos(th) + n * ct),
                 rp = (n * cos(th) - ct) / (n * cos(th) + ct);
    const double Rs = rs * rs, Rp = rp * rp, R = 0.5 * (Rs + Rp);
    const double t_pol = 0.5 * ((1.0 - Rs) / (1.0 + Rs) + (1.0 - Rp) / (1.0 + Rp));
    const double want = t_pol / ((1.0 - R) / (1.0 + R)) - 1.0;
    double got[2];
    for (int k = 0; k < 2; k++) {
        scene_t *s = lamp_scene("AttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\n"
                                "Rotate 60 1 0 0\nTranslate 0 0 0.05\n" PBRT_QUAD
                                "Translate 0 0 -0.1\n" PBRT_QUAD_BACK "AttributeEnd\n");
        assert_non_null(s);
        assert_false(s->settings.polarised);
        assert_true(polar_pilot_needed(s));
        err_t err;
        assert_int_equal(polar_pilot_apply(s, &err), 0);
        assert_true(s->settings.polar_pilot.run);
        assert_true(s->settings.polar_pilot.change_hi > POLAR_PILOT_TARGET);
        assert_false(s->settings.polarised); /* advised, not switched on */
        got[k] = s->settings.polar_pilot.change;
        if (!(fabs(got[k] - want) <= 0.02 * want))
            fail_msg("slab: pilot change %.5f, Fresnel %.5f", got[k], want);
        /* It ran once: a second call leaves the figure as it is. */
        assert_int_equal(polar_pilot_apply(s, &err), 0);
        assert_true(s->settings.polar_pilot.change == got[k]);
        scene_destroy(&s);
    }
    assert_true(got[0] == got[1]); /* deterministic */
    /* What the pilot advises, the file asks for: polarised transport carried. */
    scene_t *s = lamp_scene_with("\"bool polarized\" true",
                                 "AttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\n"
                                 "Rotate 60 1 0 0\nTranslate 0 0 0.05\n" PBRT_QUAD
                                 "Translate 0 0 -0.1\n" PBRT_QUAD_BACK "AttributeEnd\n");
    assert_non_null(s);
    assert_true(s->settings.polarised);
    assert_true(s->settings.polarised_asked);
    scene_destroy(&s);
}

static void test_mirror_and_none(void **state)
{
    (void)state;
    err_t err;
    /* A rough metal tilted 30 degrees reflecting a constant sky: one interface, and unpolarised
     * light reflected once is recorded as without polarisation -- nothing changes. */
    scene_t *s =
        sb_load_text("LookAt 0 0 5  0 0 0  0 1 0\n"
                     "Camera \"orthographic\" \"float screenwindow\" [-0.5 0.5 -0.5 0.5]\n"
                     "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
                     "Integrator \"path\" \"integer maxdepth\" [5]\n"
                     "WorldBegin\nLightSource \"infinite\" \"spectrum L\" [300 1 900 1]\n"
                     "AttributeBegin\nMaterial \"conductor\" \"float roughness\" [0.2]\nRotate 30 "
                     "1 0 0\n" PBRT_QUAD "AttributeEnd\n",
                     NULL);
    assert_non_null(s);
    assert_int_equal(polar_pilot_apply(s, &err), 0);
    assert_true(s->settings.polar_pilot.run);
    assert_true(s->settings.polar_pilot.change == 0.0);
    assert_false(s->settings.polarised);
    scene_destroy(&s);
    /* Nothing that polarises: no pilot. */
    s = lamp_scene("AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 -1\n" PBRT_QUAD
                   "AttributeEnd\n");
    assert_non_null(s);
    assert_false(polar_pilot_needed(s));
    assert_int_equal(polar_pilot_apply(s, &err), 0);
    assert_false(s->settings.polar_pilot.run);
    assert_false(s->settings.polarised);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_slab),
        cmocka_unit_test(test_mirror_and_none),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
