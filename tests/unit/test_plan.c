/* The effect plan (scene/plan.h): what every shipped scene calls for, one synthetic scene per
 * rule, integrator "auto" following the plan, and "switching an absent effect off changes
 * nothing but time": pixel data compared bit for bit where the code makes them identical, and
 * within a tolerance derived from the samples where sampling differs. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cli_run.h"
#include "files_testutil.h"

#include "pbrt_parser.h"
#include "photon_pass.h"
#include "plan.h"
#include "render.h"
#include "scene_load.h"
#include "tilebuf.h"

#include <glob.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers ---- */

typedef struct loaded {
    scene_desc_t *desc;
    scene_t *scene;
    plan_t *plan;
} loaded_t;

static void loaded_free(loaded_t *l)
{
    plan_destroy(&l->plan);
    scene_destroy(&l->scene);
    scene_desc_destroy(&l->desc);
}

/* Loads a scene (a file when text is NULL) with overrides and plans it. */
static loaded_t load(const char *path, const char *text, const scene_overrides_t *ov)
{
    loaded_t l = {0};
    err_t err = {{0}};
    l.desc = text ? pbrt_parse_string(text, strlen(text), path, &err) : pbrt_parse_file(path, &err);
    if (!l.desc)
        fail_msg("%s: %s", path, err.msg);
    l.scene = scene_load(l.desc, ov, &err);
    if (!l.scene)
        fail_msg("%s: %s", path, err.msg);
    plan_request_t req = plan_request_make(l.desc, ov);
    l.plan = plan_new(l.scene, &req, &err);
    if (!l.plan)
        fail_msg("%s: %s", path, err.msg);
    return l;
}

static loaded_t load_shipped(const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/%s", testutil_source_dir(), name);
    /* Small images: the photon parameters scale with the film, nothing else does. */
    scene_overrides_t ov = {.xres = 160, .yres = 120, .seed = -1};
    return load(path, NULL, &ov);
}

static int on(const loaded_t *l, plan_effect_t e)
{
    return plan_decision_of(l->plan, e)->on;
}

static const plan_material_t *material_named(const loaded_t *l, const char *name)
{
    for (size_t i = 0; i < plan_material_count(l->plan); i++)
        if (!strcmp(plan_material_at(l->plan, i)->name, name))
            return plan_material_at(l->plan, i);
    fail_msg("no material %s", name);
    return NULL;
}

/* The only dispersive material of a scene. */
static const plan_material_t *the_dispersive(const loaded_t *l)
{
    const plan_material_t *found = NULL;
    for (size_t i = 0; i < plan_material_count(l->plan); i++)
        if (plan_material_at(l->plan, i)->dispersive) {
            assert_null(found);
            found = plan_material_at(l->plan, i);
        }
    assert_non_null(found);
    return found;
}

/* The SCHOTT catalogue's n_d (5 decimals) and v_d (2 decimals): within their rounding. */
static void assert_catalogue(const plan_material_t *m, double n_d, double v_d)
{
    assert_true(fabs(m->n_d - n_d) <= 0.6e-5);
    assert_true(m->has_v_d);
    assert_true(fabs(m->v_d - v_d) <= 0.006);
}

static char *plan_text(const plan_t *p)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    assert_non_null(f);
    assert_int_equal(plan_write_text(p, f), 0);
    assert_int_equal(fclose(f), 0);
    return buf;
}

/* ---- synthetic scenes ---- */

/* A camera above a floor at y = 0; integrator is a whole Integrator line or "". */
static void scene_text(char *buf, size_t n, const char *integrator, const char *world)
{
    snprintf(
        buf, n,
        "LookAt 0 2.5 -4  0 0.4 0  0 1 0\n"
        "Camera \"perspective\" \"float fov\" [ 45 ]\n"
        "Film \"rgb\" \"integer xresolution\" [ 24 ] \"integer yresolution\" [ 16 ]\n"
        "Sampler \"independent\" \"integer pixelsamples\" [ 16 ]\n"
        "%s\n"
        "WorldBegin\n"
        "MakeNamedMaterial \"floor\" \"string type\" \"diffuse\" \"float reflectance\" 0.5\n"
        "MakeNamedMaterial \"wall\" \"string type\" \"diffuse\" \"float reflectance\" 0.5\n"
        "MakeNamedMaterial \"glass\" \"string type\" \"dielectric\" \"float eta\" 1.5\n"
        "MakeNamedMaterial \"mirror\" \"string type\" \"conductor\" \"float reflectance\" 0.9\n"
        "%s",
        integrator, world);
}

#define FLOOR_AT(y)                                                                                \
    "NamedMaterial \"floor\"\nShape \"trianglemesh\" \"point3 P\" [ -5 " #y " -5  5 " #y           \
    " -5  5 " #y " 5  -5 " #y " 5 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n"
#define GLASS_SPHERE                                                                               \
    "AttributeBegin\nNamedMaterial \"glass\"\nTranslate 0 0.5 0\nShape \"sphere\" \"float "        \
    "radius\" 0.3\nAttributeEnd\n"
#define POINT_ABOVE "LightSource \"point\" \"point3 from\" [ 0 2 0 ] \"float scale\" 5\n"

static loaded_t load_world(const char *integrator, const char *world)
{
    static char text[8192];
    scene_text(text, sizeof text, integrator, world);
    return load("synthetic.pbrt", text, NULL);
}

static const plan_light_t *light(const loaded_t *l, size_t i)
{
    assert_true(i < plan_light_count(l->plan));
    return plan_light_at(l->plan, i);
}

/* ---- the shipped scenes ---- */

static void test_shipped_cornell(void **state)
{
    (void)state;
    loaded_t l = load_shipped("cornell.pbrt");
    /* Constant-index glass: no splitting, n exactly 1.5 across the film. */
    assert_false(on(&l, PLAN_SPLITTING));
    assert_false(on(&l, PLAN_STRATEGY));
    const plan_material_t *g = NULL;
    for (size_t i = 0; i < plan_material_count(l.plan); i++)
        if (plan_material_at(l.plan, i)->kind == MATERIAL_DIELECTRIC)
            g = plan_material_at(l.plan, i);
    assert_non_null(g);
    assert_false(g->dispersive);
    assert_true(g->n_lo == 1.5 && g->n_hi == 1.5);
    /* The ceiling light is 0.5 x 0.5 m at y = 1.999, the glass cube's centre at (0.4, 0.3,
     * -0.25): d^2 = 0.4^2 + 1.699^2 + 0.25^2 = 3.11, cos = 1.699 / 1.764, so it subtends
     * A cos / d^2 = 0.25 * 0.963 / 3.11 = 0.0775 sr, times 0.981 for its size (a square of
     * half-side a on its axis subtends 4 asin(a^2 / (a^2 + d^2)) = 0.0789 against
     * A / d^2 = 0.0804): 0.076 sr > pi / 64, not small, no photon pass. */
    const plan_light_t *c = light(&l, 0);
    assert_true(fabs(c->solid_angle - 0.076) < 0.003);
    assert_false(c->small);
    assert_int_equal(c->verdict, PLAN_LIGHT_NOT_NEEDED);
    assert_false(on(&l, PLAN_PHOTON));
    assert_false(on(&l, PLAN_PHOTON_PARAMS));
    plan_choice_t ch = plan_choice(l.plan);
    assert_int_equal(ch.integrator, INTEGRATOR_PATH);
    assert_false(ch.photon);
    assert_false(ch.differs);
    /* Reflectances 'red' and 'green' vary with wavelength: colour is on. */
    assert_true(on(&l, PLAN_COLOUR));
    assert_true(material_named(&l, "'red'")->spectral);
    loaded_free(&l);
}

/* The Cornell box with its glass cube removed: nothing disperses, no mirror or glass at all. */
static void test_cornell_without_glass(void **state)
{
    (void)state;
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/cornell.pbrt", testutil_source_dir());
    char *text = testutil_slurp(path, NULL);
    assert_non_null(text);
    char *glass = strstr(text, "AttributeBegin\n  Material \"dielectric\"");
    assert_non_null(glass);
    *glass = 0;
    loaded_t l = load(path, text, NULL);
    assert_false(on(&l, PLAN_SPLITTING));
    assert_false(on(&l, PLAN_PHOTON));
    assert_non_null(strstr(plan_decision_of(l.plan, PLAN_SPLITTING)->reason, "no glass"));
    assert_int_equal(plan_rays(l.plan), 0);
    loaded_free(&l);
    free(text);
}

static void test_shipped_prism(void **state)
{
    (void)state;
    loaded_t l = load_shipped("prism.pbrt");
    assert_true(on(&l, PLAN_SPLITTING));
    assert_true(on(&l, PLAN_STRATEGY));
    const plan_material_t *g = the_dispersive(&l);
    assert_catalogue(g, 1.51680, 64.17); /* SCHOTT N-BK7 */
    assert_true(g->n_lo > g->n_hi);      /* normal dispersion */
    /* The ceiling light (1.4 m square) is large; each strip light is 6 cm x 2 m (0.12 m^2) on
     * the wall at x = 1.99, 2.1 to 3.2 m from the prism: 0.12 cos / d^2 ~ 0.009-0.022 sr, below
     * pi / 64 = 0.049, and each carries 20 * 0.12 / (20 * 0.36 + 6 * 1.96) = 12.7 % of the
     * power: small and bright behind glass, so photons are advised. */
    assert_int_equal(light(&l, 0)->verdict, PLAN_LIGHT_NOT_NEEDED);
    for (size_t i = 1; i <= 3; i++) {
        const plan_light_t *s = light(&l, i);
        assert_true(s->small && s->bright && s->caustic);
        assert_true(s->solid_angle > 0.005 && s->solid_angle < 0.03);
        assert_true(fabs(s->power_share - 20 * 0.12 / (20 * 0.36 + 6 * 1.96)) < 1e-3);
        assert_int_equal(s->verdict, PLAN_LIGHT_ADVISED);
    }
    /* The file asks for "path": kept, and the mismatch is reported. */
    plan_choice_t ch = plan_choice(l.plan);
    assert_true(ch.photon && ch.differs);
    assert_false(l.scene->settings.photon.enabled);
    assert_int_equal(l.scene->settings.integrator, INTEGRATOR_PATH);
    assert_non_null(strstr(plan_decision_of(l.plan, PLAN_INTEGRATOR)->reason, "mismatch"));
    loaded_free(&l);
}

static void test_shipped_prism_beam(void **state)
{
    (void)state;
    loaded_t l = load_shipped("prism_beam.pbrt");
    assert_true(on(&l, PLAN_SPLITTING));
    assert_catalogue(the_dispersive(&l), 1.72825, 28.41); /* SCHOTT SF10 */
    /* The collimated beam goes through the prism: needed (no camera path finds it). */
    const plan_light_t *b = light(&l, 1);
    assert_int_equal(b->kind, LIGHT_COLLIMATED);
    assert_true(b->reaches_specular && b->caustic);
    assert_int_equal(b->verdict, PLAN_LIGHT_NEEDED);
    assert_int_equal(light(&l, 0)->verdict, PLAN_LIGHT_NOT_NEEDED); /* the big ceiling */
    plan_choice_t ch = plan_choice(l.plan);
    assert_true(ch.photon);
    assert_false(ch.differs); /* the file asks for "photon" */
    /* Its own parameters are kept (explicit). */
    assert_true(l.scene->settings.photon.enabled);
    assert_int_equal(l.scene->settings.photon.photons, 1000000);
    assert_true(on(&l, PLAN_PHOTON_PARAMS));
    loaded_free(&l);
}

static void test_shipped_sphere_booth_and_crystal(void **state)
{
    (void)state;
    loaded_t l = load_shipped("sphere_booth.pbrt");
    assert_true(on(&l, PLAN_SPLITTING));
    assert_catalogue(the_dispersive(&l), 1.78472, 25.68); /* SCHOTT N-SF11 */
    /* A 1 m square light 2.39 m above the sphere's centre and 0.2 m aside: on its axis it
     * would subtend 4 asin(0.25 / (0.25 + 2.39^2)) = 0.1679 sr; 0.2 m off the axis the
     * distance grows by 0.35 % and the light's cosine falls to 0.9965: 0.1679 * 0.9965 /
     * 1.007 = 0.166 sr. */
    assert_true(fabs(light(&l, 0)->solid_angle - 0.166) < 0.003);
    assert_false(on(&l, PLAN_PHOTON));
    assert_false(plan_choice(l.plan).differs);
    loaded_free(&l);

    l = load_shipped("crystal.pbrt");
    assert_true(on(&l, PLAN_SPLITTING));
    assert_catalogue(the_dispersive(&l), 2.02204, 29.06); /* SCHOTT LASF35 */
    assert_false(on(&l, PLAN_PHOTON));
    loaded_free(&l);
}

/* A realistic camera whose lens disperses: no material in the scene does, yet every camera
 * path splits its wavelengths in the lens (axial and lateral colour), so splitting and the
 * strategy are on and the plan names the lens's glass with its indices at the film's ends. */
static void test_lens_dispersion(void **state)
{
    (void)state;
    loaded_t l = load_shipped("lateral_colour.pbrt");
    assert_true(on(&l, PLAN_SPLITTING));
    assert_true(on(&l, PLAN_STRATEGY));
    char *text = plan_text(l.plan);
    assert_non_null(strstr(text, "in the camera's lens"));
    /* SCHOTT N-BK7 at 380 and 720 nm (its Sellmeier fit): 1.5337 and 1.5125. */
    assert_non_null(strstr(text, "element 2 N-BK7 n 1.5337 at 380 nm to 1.5125 at 720 nm"));
    assert_non_null(strstr(text, "only the camera's lens disperses"));
    free(text);
    loaded_free(&l);
    /* The same scene through a pinhole has nothing that splits. */
    l = load_shipped("cornell.pbrt");
    assert_false(on(&l, PLAN_SPLITTING));
    loaded_free(&l);
}

/* The sun scenes: a distant light (a delta in direction) through a prism or a gem, and the
 * 8-bucket prism beam: photons are needed, and the files ask for them. */
static void test_shipped_delta_scenes(void **state)
{
    (void)state;
    const char *names[3] = {"sun_slit.pbrt", "crystal_caustic.pbrt", "prism_beam8.pbrt"};
    const light_kind_t kinds[3] = {LIGHT_DISTANT, LIGHT_DISTANT, LIGHT_COLLIMATED};
    for (int k = 0; k < 3; k++) {
        loaded_t l = load_shipped(names[k]);
        assert_true(on(&l, PLAN_SPLITTING));
        int needed = 0;
        for (size_t i = 0; i < plan_light_count(l.plan); i++) {
            const plan_light_t *p = light(&l, i);
            if (p->kind == kinds[k]) {
                assert_true(p->caustic);
                assert_int_equal(p->verdict, PLAN_LIGHT_NEEDED);
                needed++;
            }
        }
        assert_int_equal(needed, 1);
        assert_true(plan_choice(l.plan).photon);
        assert_false(plan_choice(l.plan).differs);
        loaded_free(&l);
    }
}

/* Every scene in scenes/ (including ones added later) loads, plans deterministically, and its
 * splitting decision is the scene's has_dispersion or its camera lens's dispersion. */
static void test_every_shipped_scene(void **state)
{
    (void)state;
    char pattern[1024];
    snprintf(pattern, sizeof pattern, "%s/scenes/*.pbrt", testutil_source_dir());
    glob_t g;
    assert_int_equal(glob(pattern, 0, NULL, &g), 0);
    assert_true(g.gl_pathc >= 5);
    for (size_t i = 0; i < g.gl_pathc; i++) {
        scene_overrides_t ov = {.xres = 160, .yres = 120, .seed = -1};
        loaded_t a = load(g.gl_pathv[i], NULL, &ov), b = load(g.gl_pathv[i], NULL, &ov);
        const camera_t *cam = &a.scene->camera;
        assert_int_equal(on(&a, PLAN_SPLITTING),
                         a.scene->has_dispersion ||
                             (cam->kind == CAMERA_REALISTIC && cam->lens_dispersive));
        char *ta = plan_text(a.plan), *tb = plan_text(b.plan);
        assert_string_equal(ta, tb);
        free(ta);
        free(tb);
        /* A scene asking for "photon" where the plan sees no caustic would be a wasted pass. */
        if (a.scene->settings.photon.enabled)
            assert_true(plan_choice(a.plan).photon);
        loaded_free(&a);
        loaded_free(&b);
    }
    globfree(&g);
}

/* ---- one synthetic scene per rule ---- */

static void test_point_light_behind_glass(void **state)
{
    (void)state;
    loaded_t l = load_world("", FLOOR_AT(0) GLASS_SPHERE POINT_ABOVE);
    const plan_light_t *p = light(&l, 0);
    assert_true(p->reaches_specular && p->caustic);
    assert_string_equal(plan_material_at(l.plan, (size_t)p->glass_material)->name, "'glass'");
    assert_string_equal(plan_material_at(l.plan, (size_t)p->receiver_material)->name, "'floor'");
    assert_int_equal(p->verdict, PLAN_LIGHT_NEEDED);
    assert_true(on(&l, PLAN_PHOTON));
    assert_false(on(&l, PLAN_SPLITTING)); /* constant n = 1.5 */
    loaded_free(&l);

    /* A distant light straight down: needed as well. */
    l = load_world("", FLOOR_AT(0) GLASS_SPHERE
                   "LightSource \"distant\" \"point3 from\" [ 0 1 0 ] \"point3 to\" [ 0 0 0 ]\n");
    assert_int_equal(light(&l, 0)->verdict, PLAN_LIGHT_NEEDED);
    loaded_free(&l);

    /* A spot at the same place: aimed down at the sphere it is needed, aimed up it never
     * reaches the glass. */
    l = load_world("", FLOOR_AT(0) GLASS_SPHERE
                   "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 0 0 ] "
                   "\"float coneangle\" 20\n");
    assert_int_equal(light(&l, 0)->verdict, PLAN_LIGHT_NEEDED);
    loaded_free(&l);
    l = load_world("", FLOOR_AT(0) GLASS_SPHERE
                   "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 4 0 ] "
                   "\"float coneangle\" 20\n");
    assert_false(light(&l, 0)->reaches_specular);
    assert_false(on(&l, PLAN_PHOTON));
    loaded_free(&l);

    /* A projection light there (tests/data's 2x2 checker, fov 30): looking down (the CTM's +z
     * turned to -y) it lights the glass and needs photons; looking up it reaches nothing. */
    l = load_world("", FLOOR_AT(0) GLASS_SPHERE
                   "AttributeBegin\nTranslate 0 2 0\nRotate 90 1 0 0\nLightSource \"projection\" "
                   "\"string filename\" \"data/scene_checker2x2.png\" \"float fov\" 30\nAttributeEnd\n");
    assert_int_equal(light(&l, 0)->kind, LIGHT_PROJECTION);
    assert_string_equal(plan_light_kind_name(LIGHT_PROJECTION), "projection");
    assert_int_equal(light(&l, 0)->verdict, PLAN_LIGHT_NEEDED);
    loaded_free(&l);
    l = load_world("", FLOOR_AT(0) GLASS_SPHERE
                   "AttributeBegin\nTranslate 0 2 0\nRotate -90 1 0 0\nLightSource \"projection\" "
                   "\"string filename\" \"data/scene_checker2x2.png\" \"float fov\" 30\nAttributeEnd\n");
    assert_false(light(&l, 0)->reaches_specular);
    assert_false(on(&l, PLAN_PHOTON));
    loaded_free(&l);
}

/* The gather radius is one pixel footprint at the specular surfaces' distance from the camera
 * (docs/plan.md): from the camera at (0, 2.5, -4) the glass sphere's centre (0, 0.5, 0) is
 * sqrt(20) away, and a 45 degree fov over the 16-pixel side gives a footprint of
 * 2 sqrt(20) tan(22.5 deg) / 16 = 0.2315 (below the cap of 0.05 of the scene's radius). Two
 * footprints, the rule before, blurred caustic-glass's edges past what noise explains. */
static void test_gather_radius_one_footprint(void **state)
{
    (void)state;
    loaded_t l = load_world("", FLOOR_AT(0) GLASS_SPHERE POINT_ABOVE);
    assert_true(on(&l, PLAN_PHOTON));
    const double footprint = 2.0 * sqrt(20.0) * tan(22.5 * PF_PI / 180.0) / 16.0;
    assert_true(fabs(plan_choice(l.plan).radius - footprint) < 1e-9 * footprint);
    assert_true(fabs(l.scene->settings.photon.radius - footprint) < 1e-9 * footprint);
    loaded_free(&l);
}

/* A cropped film renders the full film's pixels (scene.h: same camera, same random numbers), so
 * its photon pass must be the full film's too: sized from the cropped image, a quarter crop of
 * volumetric-caustic got 110000 photons and a 4x radius instead of 1.74 million, and its pixels
 * were not the full render's. */
static void test_crop_keeps_photon_pass(void **state)
{
    (void)state;
    static char text[8192], cropped[8192];
    scene_text(text, sizeof text, "", FLOOR_AT(0) GLASS_SPHERE POINT_ABOVE);
    const char *film = "Film \"rgb\"";
    const char *at = strstr(text, film);
    assert_non_null(at);
    snprintf(cropped, sizeof cropped, "%.*s%s \"float cropwindow\" [ 0 0.5 0.5 1 ]%s",
             (int)(at - text), text, film, at + strlen(film));
    loaded_t full = load("full.pbrt", text, NULL), crop = load("crop.pbrt", cropped, NULL);
    assert_int_equal(crop.scene->settings.xres, 12); /* the crop did take */
    assert_true(on(&full, PLAN_PHOTON) && on(&crop, PLAN_PHOTON));
    assert_int_equal(plan_choice(crop.plan).photons, plan_choice(full.plan).photons);
    assert_true(plan_choice(crop.plan).radius == plan_choice(full.plan).radius);
    assert_int_equal(crop.scene->settings.photon.photons, full.scene->settings.photon.photons);
    loaded_free(&full);
    loaded_free(&crop);
}

/* A glossy receiver (coated diffuse, rough conductor) under the glass receives its caustic as a
 * diffuse one does (the photon map stores L S+ G photons with their directions), so the spot
 * light behind glass needs photons there too. pbrt-v4's light-path integrators (bdpt, mlt,
 * lightpath) take the plan's photon pass and keep their own mapping otherwise; "path" is
 * explicit and stays without. A floor of smooth glass receives nothing. */
static void test_glossy_receiver_and_bdpt(void **state)
{
    (void)state;
    const char *floors[2] = {
        "MakeNamedMaterial \"gfloor\" \"string type\" \"coateddiffuse\" \"float roughness\" 0.01\n",
        "MakeNamedMaterial \"gfloor\" \"string type\" \"conductor\" \"float roughness\" 0.2\n"};
    const char *integrators[5] = {"Integrator \"bdpt\"", "Integrator \"mlt\"",
                                  "Integrator \"lightpath\"", "", "Integrator \"path\""};
    char world[2048];
    for (int f = 0; f < 2; f++)
        for (int k = 0; k < 5; k++) {
            snprintf(world, sizeof world,
                     "%sNamedMaterial \"gfloor\"\nShape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 "
                     "-5  5 0 5  -5 0 5 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n" GLASS_SPHERE
                     "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 0 0 ] "
                     "\"float coneangle\" 20\n",
                     floors[f]);
            loaded_t l = load_world(integrators[k], world);
            const plan_light_t *p = light(&l, 0);
            assert_true(p->caustic);
            assert_int_equal(p->verdict, PLAN_LIGHT_NEEDED);
            assert_string_equal(plan_material_at(l.plan, (size_t)p->receiver_material)->name,
                                "'gfloor'");
            assert_true(on(&l, PLAN_PHOTON));
            const render_settings_t *rs = &l.scene->settings;
            assert_int_equal(rs->integrator, INTEGRATOR_PATH);
            if (k < 4) {
                assert_true(rs->photon.enabled);
                assert_int_equal(rs->photon.store, PHOTON_STORE_PHOTONMAP);
                assert_int_equal(rs->photon.photons, plan_choice(l.plan).photons);
                assert_false(plan_choice(l.plan).differs);
            } else {
                assert_false(rs->photon.enabled);
                assert_true(plan_choice(l.plan).differs);
            }
            if (k < 3) {
                /* The plan says why the light-path integrator got photons. */
                assert_non_null(strstr(plan_decision_of(l.plan, PLAN_INTEGRATOR)->reason,
                                       "traces paths from the lights"));
                assert_non_null(strstr(plan_decision_of(l.plan, PLAN_PHOTON)->reason,
                                       "L S+ D or L S+ G path from a delta light"));
            }
            loaded_free(&l);
        }
    /* bdpt without a caustic: no photon pass, and the path tracer alone. */
    loaded_t l = load_world("Integrator \"bdpt\"", FLOOR_AT(0) POINT_ABOVE);
    assert_false(on(&l, PLAN_PHOTON));
    assert_false(l.scene->settings.photon.enabled);
    loaded_free(&l);
    /* A smooth glass floor is no receiver. */
    l = load_world("Integrator \"bdpt\"",
                   "NamedMaterial \"glass\"\nShape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 -5  "
                   "5 0 5  -5 0 5 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n" GLASS_SPHERE
                   "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 0 0 ] "
                   "\"float coneangle\" 20\n");
    assert_false(light(&l, 0)->caustic);
    assert_false(l.scene->settings.photon.enabled);
    loaded_free(&l);
}

/* A scene with simulated media (bdpt and "auto" simulate them) whose spot light's caustic
 * calls for photons: both passes carry the media (render/photon_volume.h), so the plan keeps
 * the photon pass and the media, and says so in the photon decision. */
static void test_media_keep_camera_pass(void **state)
{
    (void)state;
    const char *integrators[2] = {"Integrator \"bdpt\"", ""};
    for (int k = 0; k < 2; k++) {
        loaded_t l = load_world(integrators[k],
                                "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_s\" "
                                "[0.05 0.05 0.05] \"rgb sigma_a\" [0 0 0]\n"
                                "AttributeBegin\nMediumInterface \"\" \"fog\"\n" FLOOR_AT(0) GLASS_SPHERE
                                "AttributeEnd\n"
                                "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 0 0 ] "
                                "\"float coneangle\" 20\n");
        assert_int_equal(light(&l, 0)->verdict, PLAN_LIGHT_NEEDED);
        assert_true(on(&l, PLAN_PHOTON));
        assert_non_null(strstr(plan_decision_of(l.plan, PLAN_PHOTON)->reason, "volume photons"));
        assert_non_null(strstr(plan_decision_of(l.plan, PLAN_PHOTON)->reason, "volumetric caustic"));
        assert_true(l.scene->settings.media);
        assert_true(l.scene->settings.photon.enabled);
        loaded_free(&l);
    }
}

/* The point light shut in a small diffuse box: it reaches no glass. */
static void test_blocked_light(void **state)
{
    (void)state;
    loaded_t l = load_world(
        "", FLOOR_AT(0) GLASS_SPHERE POINT_ABOVE
        "NamedMaterial \"wall\"\nTranslate 0 2 0\nScale 0.1 0.1 0.1\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 -1  1 -1 -1  1 -1 1  -1 -1 1  -1 1 -1  1 1 -1 "
        " "
        "1 1 1  -1 1 1 ] \"integer indices\" [ 0 1 2  0 2 3  4 6 5  4 7 6  0 5 1  0 4 5  1 6 2  "
        "1 5 6  2 7 3  2 6 7  3 4 0  3 7 4 ]\n");
    assert_false(light(&l, 0)->reaches_specular);
    assert_int_equal(light(&l, 0)->verdict, PLAN_LIGHT_NOT_NEEDED);
    assert_false(on(&l, PLAN_PHOTON));
    loaded_free(&l);
}

static void test_diffuse_only(void **state)
{
    (void)state;
    loaded_t l = load_world("", FLOOR_AT(0) POINT_ABOVE
                            "NamedMaterial \"wall\"\nShape \"sphere\" \"float radius\" 0.3\n");
    assert_false(on(&l, PLAN_SPLITTING));
    assert_false(on(&l, PLAN_STRATEGY));
    assert_false(on(&l, PLAN_PHOTON));
    assert_false(on(&l, PLAN_PHOTON_PARAMS));
    /* Reflectances are "float" constants; the point light's D65 varies. */
    assert_true(on(&l, PLAN_COLOUR));
    assert_false(material_named(&l, "'floor'")->spectral);
    assert_true(light(&l, 0)->spectral);
    assert_int_equal(l.scene->settings.integrator, INTEGRATOR_PATH);
    assert_false(l.scene->settings.photon.enabled);
    loaded_free(&l);

    /* Flat emission too: nothing varies with wavelength. */
    l = load_world(
        "",
        FLOOR_AT(
            0) "LightSource \"point\" \"point3 from\" [ 0 2 0 ] \"spectrum I\" [ 300 1 900 1 ]\n");
    assert_false(on(&l, PLAN_COLOUR));
    loaded_free(&l);
}

/* A mirror facing up under a point light with nothing above it: the floor below sees only its
 * back, where no light arrives, so no caustic. A ceiling above makes one. */
#define MIRROR_UP                                                                                  \
    "AttributeBegin\nNamedMaterial \"mirror\"\nRotate -90 1 0 0\nShape \"disk\" \"float radius\" " \
    "0.5\nAttributeEnd\n"
static void test_mirror_nobody_sees(void **state)
{
    (void)state;
    loaded_t l = load_world("", FLOOR_AT(-1) MIRROR_UP POINT_ABOVE);
    const plan_light_t *p = light(&l, 0);
    assert_true(p->reaches_specular);
    assert_false(p->caustic);
    assert_false(on(&l, PLAN_PHOTON));
    loaded_free(&l);

    l = load_world("", FLOOR_AT(-1) MIRROR_UP POINT_ABOVE
                   "NamedMaterial \"wall\"\nShape \"trianglemesh\" \"point3 P\" [ -5 3 -5  5 3 -5  "
                   "5 3 5  -5 3 5 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n");
    p = light(&l, 0);
    assert_true(p->caustic);
    assert_string_equal(plan_material_at(l.plan, (size_t)p->receiver_material)->name, "'wall'");
    assert_string_equal(plan_material_at(l.plan, (size_t)p->glass_material)->name, "'mirror'");
    assert_true(on(&l, PLAN_PHOTON));
    loaded_free(&l);
}

/* Area lights: a disk of radius a facing the glass sphere's centre from h = 1.5 subtends
 * exactly 2 pi (1 - h / sqrt(h^2 + a^2)) sr. */
static void test_small_and_large_area_lights(void **state)
{
    (void)state;
    char world[2048];
    const double h = 1.5;
    double radii[2] = {0.05, 1.5};
    for (int k = 0; k < 2; k++) {
        double a = radii[k];
        snprintf(
            world, sizeof world,
            FLOOR_AT(0) GLASS_SPHERE
            "AttributeBegin\nAreaLightSource \"diffuse\" \"float scale\" 10\n"
            "Translate 0 2 0\nRotate 90 1 0 0\nShape \"disk\" \"float radius\" %g\nAttributeEnd\n",
            a);
        loaded_t l = load_world("", world);
        const plan_light_t *p = light(&l, 0);
        double exact = 2.0 * PF_PI * (1.0 - h / sqrt(h * h + a * a));
        if (k == 0) {
            /* 64 points of a disk whose cos / d^2 varies by 0.2 %: well within 1 %. */
            assert_true(fabs(p->solid_angle / exact - 1.0) < 0.01);
            assert_true(p->small && p->bright && p->caustic);
            assert_int_equal(p->verdict, PLAN_LIGHT_ADVISED);
            assert_true(on(&l, PLAN_PHOTON));
        } else {
            /* cos / d^2 varies by a factor 2.8 over this disk: 64 points give ~5 %. */
            assert_true(fabs(p->solid_angle / exact - 1.0) < 0.15);
            assert_false(p->small);
            assert_int_equal(p->verdict, PLAN_LIGHT_NOT_NEEDED);
            assert_false(on(&l, PLAN_PHOTON));
        }
        loaded_free(&l);
    }
    /* The small light beside a big bright one far above: 1 * pi * (pi 0.05^2) against
     * 1 * pi * (pi 2^2) is 0.06 % of the power, so it is small but dim. */
    loaded_t l = load_world(
        "", FLOOR_AT(0) GLASS_SPHERE
        "AttributeBegin\nAreaLightSource \"diffuse\" \"float scale\" 1\nTranslate 0 2 0\n"
        "Rotate 90 1 0 0\nShape \"disk\" \"float radius\" 0.05\nAttributeEnd\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"float scale\" 1\nTranslate 0 5 0\n"
        "Rotate 90 1 0 0\nShape \"disk\" \"float radius\" 2\nAttributeEnd\n");
    assert_true(light(&l, 0)->small);
    assert_false(light(&l, 0)->bright);
    assert_true(fabs(light(&l, 0)->power_share - 0.0025 / (0.0025 + 4.0)) < 1e-9);
    assert_false(on(&l, PLAN_PHOTON));
    loaded_free(&l);
}

/* A collimated beam on a diffuse wall, no glass anywhere: its light exists only as photons. */
static void test_collimated_direct(void **state)
{
    (void)state;
    loaded_t l = load_world(
        "", "NamedMaterial \"wall\"\nShape \"trianglemesh\" \"point3 P\" [ -5 0 2  5 0 2  5 5 2  "
            "-5 5 2 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n"
            "AttributeBegin\nAreaLightSource \"collimated\" \"float scale\" 10\nMaterial "
            "\"interface\"\n"
            "Translate 0 1 -1\nShape \"disk\" \"float radius\" 0.1\nAttributeEnd\n");
    const plan_light_t *p = light(&l, 0);
    assert_true(p->direct);
    assert_false(p->caustic);
    assert_string_equal(plan_material_at(l.plan, (size_t)p->receiver_material)->name, "'wall'");
    assert_int_equal(p->verdict, PLAN_LIGHT_NEEDED);
    assert_true(on(&l, PLAN_PHOTON));
    /* No mirror or glass to size the pass against: the fewest photons. */
    assert_int_equal(plan_choice(l.plan).photons, 100000);
    loaded_free(&l);
}

/* Cauchy glass n = A + B / L^2: the spread over 380-720 nm is B (1/0.38^2 - 1/0.72^2). */
static void test_cauchy_spread(void **state)
{
    (void)state;
    loaded_t l = load_world(
        "", FLOOR_AT(0) POINT_ABOVE
        "MakeNamedMaterial \"flint\" \"string type\" \"dielectric\" \"float cauchy\" [ 1.5 0.0042 "
        "]\n"
        "NamedMaterial \"flint\"\nTranslate 0 0.5 0\nShape \"sphere\" \"float radius\" 0.3\n");
    const plan_material_t *m = material_named(&l, "'flint'");
    assert_true(m->dispersive);
    double lo = 1.5 + 0.0042 / (0.38 * 0.38), hi = 1.5 + 0.0042 / (0.72 * 0.72),
           mid = 1.5 + 0.0042 / (0.55 * 0.55);
    assert_true(fabs(m->n_lo - lo) < 1e-12 && fabs(m->n_hi - hi) < 1e-12);
    assert_true(fabs(m->v_film - (mid - 1.0) / (lo - hi)) < 1e-9);
    assert_true(on(&l, PLAN_SPLITTING));
    assert_non_null(strstr(plan_decision_of(l.plan, PLAN_SPLITTING)->reason, "'flint'"));
    loaded_free(&l);
}

/* ---- integrator "auto" ---- */

static void test_auto_follows_plan(void **state)
{
    (void)state;
    const char *world = FLOOR_AT(0) GLASS_SPHERE POINT_ABOVE;
    /* No Integrator directive, and Integrator "auto": the plan's photon pass. */
    const char *lines[2] = {"", "Integrator \"auto\" \"integer maxdepth\" 7"};
    for (int k = 0; k < 2; k++) {
        loaded_t l = load_world(lines[k], world);
        plan_choice_t ch = plan_choice(l.plan);
        const render_settings_t *rs = &l.scene->settings;
        assert_true(ch.photon);
        assert_true(rs->photon.enabled);
        assert_int_equal(rs->photon.photons, ch.photons);
        assert_true(rs->photon.radius == ch.radius);
        assert_int_equal(rs->integrator, INTEGRATOR_PATH);
        assert_int_equal(rs->dispersion, DISPERSION_HERO);
        assert_int_equal(rs->photon.maxdepth, k ? 7 : 5);
        assert_int_equal(plan_request(l.plan)->integrator_named, k);
        assert_false(ch.differs);
        /* 24 x 16 pixels: the smallest count (test_gather_radius_one_footprint: the radius). */
        assert_int_equal(ch.photons, 100000);
        loaded_free(&l);
    }
    /* An explicit "path" is kept; the mismatch is noted. */
    loaded_t l = load_world("Integrator \"path\"", world);
    assert_false(l.scene->settings.photon.enabled);
    assert_true(plan_choice(l.plan).differs);
    loaded_free(&l);
    /* The command line's integrator wins over "auto". */
    static char text[8192];
    scene_text(text, sizeof text, "", world);
    scene_overrides_t ov = {.seed = -1, .integrator = "whitted"};
    l = load("synthetic.pbrt", text, &ov);
    assert_int_equal(l.scene->settings.integrator, INTEGRATOR_WHITTED);
    assert_false(l.scene->settings.photon.enabled);
    assert_true(plan_request(l.plan)->overridden);
    assert_true(plan_choice(l.plan).differs);
    loaded_free(&l);
    /* An explicit strategy under "auto" is kept. */
    l = load_world("Integrator \"auto\" \"string dispersion\" \"fanout\"", world);
    assert_int_equal(l.scene->settings.dispersion, DISPERSION_FANOUT);
    assert_true(l.scene->settings.photon.enabled);
    loaded_free(&l);
}

/* ---- switching an absent effect off changes nothing ---- */

static tilebuf_t *render_all(const scene_t *s)
{
    const render_settings_t *rs = &s->settings;
    err_t err;
    photon_store_t *photons = NULL;
    if (rs->photon.enabled && !(photons = photon_pass_run(s, 0, NULL, NULL, &err)))
        fail_msg("photon pass: %s", err.msg);
    tilebuf_t *t = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    assert_non_null(t);
    render_stats_t st = {0};
    if (render_tile(s, photons, 0, 0, rs->xres, rs->yres, 0, (uint32_t)rs->spp, t, &st, &err))
        fail_msg("render: %s", err.msg);
    photon_store_destroy(&photons);
    assert_int_equal(st.nonfinite, 0);
    return t;
}

static void assert_same_pixels(const tilebuf_t *a, const tilebuf_t *b)
{
    size_t n = (size_t)tilebuf_width(a) * (size_t)tilebuf_height(a) * (size_t)tilebuf_nbuckets(a);
    assert_int_equal(tilebuf_width(a), tilebuf_width(b));
    assert_int_equal(tilebuf_height(a), tilebuf_height(b));
    assert_memory_equal(tilebuf_sums(a), tilebuf_sums(b), n * sizeof(double));
    double total = 0.0;
    for (size_t i = 0; i < n; i++)
        total += tilebuf_sums(a)[i];
    assert_true(total > 0.0); /* not two black images */
}

/* A scene without caustic paths: "auto" and an explicit "path" give the same pixels; so does
 * an explicit "photon" (the pass runs, stores nothing, and the gather adds nothing). */
static void test_no_caustic_same_pixels(void **state)
{
    (void)state;
    const char *world = FLOOR_AT(-1) MIRROR_UP POINT_ABOVE;
    loaded_t a = load_world("", world);
    assert_false(plan_choice(a.plan).photon);
    loaded_t p = load_world("Integrator \"path\"", world);
    loaded_t ph = load_world("Integrator \"photon\" \"integer photons\" 20000", world);
    assert_true(ph.scene->settings.photon.enabled);
    assert_true(plan_choice(ph.plan).differs);
    tilebuf_t *ta = render_all(a.scene), *tp = render_all(p.scene), *tph = render_all(ph.scene);
    assert_same_pixels(ta, tp);
    assert_same_pixels(tph, tp);
    photon_stats_t st = {0};
    err_t err;
    photon_store_t *store = photon_pass_run(ph.scene, 0, &st, NULL, &err);
    assert_non_null(store);
    photon_store_destroy(&store);
    assert_int_equal(st.emitted, 20000);
    assert_int_equal(st.deposited, 0);
    tilebuf_destroy(&ta);
    tilebuf_destroy(&tp);
    tilebuf_destroy(&tph);
    loaded_free(&a);
    loaded_free(&p);
    loaded_free(&ph);
}

/* No dispersive material, flat spectra (constant reflectance 0.5, flat emission, n = 1.5
 * glass): hero and fan-out trace the same paths with the same random numbers, since every lane
 * carries the same value and no refraction depends on wavelength. Each sample's total over
 * buckets is then the same -- fan-out puts v in each of the N buckets, hero v N / 4 in the 4
 * buckets of its wavelengths -- so the per-pixel bucket sums agree to rounding. Only the
 * split between buckets differs: hero's buckets b, b+4, b+8, b+12 form a class that gets the
 * samples whose hero wavelength falls in the class (exactly 4 of 16 per pixel, stratified),
 * so each class mean per pixel is a 4-of-16 subsample (times 4) of the same values fan-out
 * averages. Its deviation from fan-out, summed over the image, is compared with 4 standard
 * errors estimated from the spread of the 4 classes in each pixel. */
static void test_hero_fanout_same_without_dispersion(void **state)
{
    (void)state;
    const char *world = FLOOR_AT(0) GLASS_SPHERE
        "AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [ 300 1 900 1 ] \"float "
        "scale\" 8\n"
        "Translate 0 2 0\nRotate 90 1 0 0\nShape \"disk\" \"float radius\" 0.5\nAttributeEnd\n";
    loaded_t h = load_world(
        "Integrator \"path\" \"integer maxdepth\" 8 \"string dispersion\" \"hero\"", world);
    loaded_t f = load_world(
        "Integrator \"path\" \"integer maxdepth\" 8 \"string dispersion\" \"fanout\"", world);
    assert_false(h.scene->has_dispersion);
    assert_false(on(&h, PLAN_COLOUR));
    tilebuf_t *th = render_all(h.scene), *tf = render_all(f.scene);
    const int w = tilebuf_width(th), hh = tilebuf_height(th), nb = tilebuf_nbuckets(th);
    assert_int_equal(nb, 16);
    double dev[4] = {0}, var = 0.0, total = 0.0, spread = 0.0;
    for (int y = 0; y < hh; y++)
        for (int x = 0; x < w; x++) {
            double sh = 0.0, sf = 0.0;
            for (int b = 0; b < nb; b++) {
                sh += tilebuf_sum(th, x, y, b);
                sf += tilebuf_sum(tf, x, y, b);
            }
            assert_true(fabs(sh - sf) <= 1e-9 * fabs(sf) + 1e-300);
            double fb = sf / nb; /* every fan-out bucket (flat spectra) */
            for (int b = 0; b < nb; b++)
                assert_true(fabs(tilebuf_sum(tf, x, y, b) - fb) <= 1e-9 * fabs(fb) + 1e-300);
            double pv = 0.0;
            for (int c = 0; c < 4; c++) {
                double m = 0.0;
                for (int b = c; b < nb; b += 4)
                    m += tilebuf_sum(th, x, y, b) / 4.0;
                dev[c] += m - fb;
                pv += (m - fb) * (m - fb);
                spread += fabs(m - fb);
            }
            var += pv / 3.0;
            total += sf;
        }
    assert_true(total > 0.0);
    assert_true(spread > 1e-6 * total); /* hero's colour noise is there: the test is live */
    double se = sqrt(var);
    for (int c = 0; c < 4; c++)
        if (!(fabs(dev[c]) <= 4.0 * se))
            fail_msg("class %d: hero - fanout = %g over the image, 4 standard errors %g", c, dev[c],
                     4.0 * se);
    tilebuf_destroy(&th);
    tilebuf_destroy(&tf);
    loaded_free(&h);
    loaded_free(&f);
}

/* ---- the command ---- */

static void test_cli_plan(void **state)
{
    (void)state;
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/prism_beam.pbrt", testutil_source_dir());
    const run_t *r = run("plan", path, "--res", "160x120", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "photon pass");
    expect_in(r->out, "collimated");
    expect_in(r->out, "SWITCHED OFF");
    r = run("plan", path, "--json", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"switched_off\"");
    expect_in(r->out, "\"photon\": true");
    snprintf(path, sizeof path, "%s/scenes/cornell.pbrt", testutil_source_dir());
    r = run("plan", path, "--json", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"photon pass\"");
    expect_in(r->out, "\"photon\": false");
    /* Bad command lines: 2; an unreadable scene: 1. */
    assert_int_equal(run("plan", NULL)->status, 2);
    assert_int_equal(run("plan", path, "--bogus", NULL)->status, 2);
    assert_int_equal(run("plan", path, "--spp", NULL)->status, 2);
    assert_int_equal(run("plan", path, "--spp", "0", NULL)->status, 2);
    assert_int_equal(run("plan", path, path, NULL)->status, 2);
    r = run("plan", "no-such-scene.pbrt", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "no-such-scene.pbrt");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shipped_cornell),
        cmocka_unit_test(test_cornell_without_glass),
        cmocka_unit_test(test_shipped_prism),
        cmocka_unit_test(test_shipped_prism_beam),
        cmocka_unit_test(test_shipped_sphere_booth_and_crystal),
        cmocka_unit_test(test_lens_dispersion),
        cmocka_unit_test(test_shipped_delta_scenes),
        cmocka_unit_test(test_every_shipped_scene),
        cmocka_unit_test(test_point_light_behind_glass),
        cmocka_unit_test(test_gather_radius_one_footprint),
        cmocka_unit_test(test_crop_keeps_photon_pass),
        cmocka_unit_test(test_glossy_receiver_and_bdpt),
        cmocka_unit_test(test_media_keep_camera_pass),
        cmocka_unit_test(test_blocked_light),
        cmocka_unit_test(test_diffuse_only),
        cmocka_unit_test(test_mirror_nobody_sees),
        cmocka_unit_test(test_small_and_large_area_lights),
        cmocka_unit_test(test_collimated_direct),
        cmocka_unit_test(test_cauchy_spread),
        cmocka_unit_test(test_auto_follows_plan),
        cmocka_unit_test(test_no_caustic_same_pixels),
        cmocka_unit_test(test_hero_fanout_same_without_dispersion),
        cmocka_unit_test(test_cli_plan),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
