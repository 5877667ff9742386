/* Goniometric and projection lights (pbrt-v4 GoniometricLight, ProjectionLight) loaded from
 * pbrt-v4 text: a goniometric light of a constant image is a point light of the same
 * intensity; an image bright in one hemisphere lights only that side (pbrt-v4's swap of y and
 * z puts the image centre along the CTM's +y); a projection light's footprint on a plane is its
 * frustum (corners from tan(fov / 2) and the aspect), its image lands upright, and "power"
 * follows pbrt-v4's formula; the photon pass delivers to each part of a diffuse plane the energy
 * that next-event estimation integrates there; black images give zeros, never NaN. The
 * oracles are written out here from the formulas, not taken from the renderer. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "equal_area.h"
#include "files_testutil.h"
#include "lights.h"
#include "photon.h"
#include "rng.h"
#include "scene_builders.h"

#define PI 3.14159265358979323846

typedef void (*texel_fn)(int x, int y, int w, int h, float rgb[3]);

/* Writes a w x h little-endian PFM whose texel (x, y) (y = 0 the top row) is fn's; returns its
 * path in the scratch folder. */
static const char *write_pfm(const char *name, int w, int h, texel_fn fn)
{
    const char *path = testutil_scratch(name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fprintf(f, "PF\n%d %d\n-1\n", w, h);
    for (int fy = 0; fy < h; fy++) /* PFM rows run bottom to top */
        for (int x = 0; x < w; x++) {
            float rgb[3];
            fn(x, h - 1 - fy, w, h, rgb);
            assert_int_equal(fwrite(rgb, sizeof(float), 3, f), 3);
        }
    fclose(f);
    return path;
}

static void grey_quarter(int x, int y, int w, int h, float rgb[3])
{
    (void)x, (void)y, (void)w, (void)h;
    rgb[0] = rgb[1] = rgb[2] = 0.25f;
}

static void black(int x, int y, int w, int h, float rgb[3])
{
    (void)x, (void)y, (void)w, (void)h;
    rgb[0] = rgb[1] = rgb[2] = 0.0f;
}

static void white(int x, int y, int w, int h, float rgb[3])
{
    (void)x, (void)y, (void)w, (void)h;
    rgb[0] = rgb[1] = rgb[2] = 1.0f;
}

/* Bright where the texel's equal-area direction has z > 0 (light space). */
static void upper_half(int x, int y, int w, int h, float rgb[3])
{
    vec3_t d = equal_area_square_to_sphere((x + 0.5) / w, (y + 0.5) / h);
    rgb[0] = rgb[1] = rgb[2] = d.z > 0 ? 2.0f : 0.0f;
}

/* Coloured rings about light-space -z (the CTM's -y after pbrt-v4's swap). */
static void rings(int x, int y, int w, int h, float rgb[3])
{
    vec3_t d = equal_area_square_to_sphere((x + 0.5) / w, (y + 0.5) / h);
    double th = acos(fmax(-1.0, fmin(1.0, -d.z)));
    float v = ((int)(th / (PI / 12)) % 2 == 0) ? 1.0f : 0.1f;
    rgb[0] = v, rgb[1] = 0.8f * v, rgb[2] = 0.4f * v;
}

static void top_left_only(int x, int y, int w, int h, float rgb[3])
{
    (void)w, (void)h;
    rgb[0] = rgb[1] = rgb[2] = (x == 0 && y == 0) ? 1.0f : 0.0f;
}

/* A few saturated colours in a pattern (projection images). */
static void colours(int x, int y, int w, int h, float rgb[3])
{
    (void)w, (void)h;
    static const float c[5][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {0.2f, 0.5f, 0.9f}};
    const float *p = c[(x + 2 * y) % 5];
    rgb[0] = p[0], rgb[1] = p[1], rgb[2] = p[2];
}

/* The scene of text with a floor quad y = 0 of half-size 3 (diffuse) after the light lines. */
static scene_t *load_with_floor(const char *light_lines, err_t *err)
{
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 3 -3  0 0 0  0 1 0\nCamera \"perspective\"\n"
             "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\nWorldBegin\n%s\n"
             "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
             "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"
             "  \"point3 P\" [-3 0 -3  3 0 -3  3 0 3  -3 0 3]\n",
             light_lines);
    return sb_load_text(text, err);
}

static const light_t *only_light(const scene_t *s)
{
    assert_int_equal(s->nlights, 1);
    return &s->lights[0];
}

/* lights_sample_emission_of at p for the scene's one light, 0 when nothing is sampled. */
static double emission_at(const scene_t *s, vec3_t p, double lambda, light_sample_t *ls)
{
    const double u[4] = {0.5, 0.5, 0.5, 0.5};
    if (!lights_sample(s, &(lights_at_t){p, {0, 0, 0}, 0}, u, ls))
        return 0.0;
    double e =
        lights_sample_emission_of(s, ls, lights_value(&s->lights[ls->light], lambda), lambda);
    assert_true(isfinite(e) && e >= 0.0);
    return e;
}

/* A goniometric light of a constant image c and scale k emits the intensity of a point light
 * of scale k c at every point and wavelength (its spectrum is the same normalised D65), and its
 * power is 4 pi k c (pbrt-v4 GoniometricLight::Phi, luminance 1 per unit scale); "power" P gives
 * power P whatever the image. */
static void test_goniometric_constant_is_point(void **state)
{
    (void)state;
    const char *img = write_pfm("grey.pfm", 8, 8, grey_quarter);
    char lines[1024];
    snprintf(
        lines, sizeof lines,
        "AttributeBegin\nTranslate 0.3 1.5 -0.2\n"
        "LightSource \"goniometric\" \"string filename\" \"%s\" \"float scale\" 4\nAttributeEnd",
        img);
    scene_t *g = load_with_floor(lines, NULL);
    scene_t *p = load_with_floor("LightSource \"point\" \"point3 from\" [0.3 1.5 -0.2]", NULL);
    assert_int_equal(only_light(g)->kind, LIGHT_GONIOMETRIC);
    assert_true(fabs(scene_light_power(g, only_light(g)) / (4.0 * PI) - 1.0) < 1e-9);
    assert_true(fabs(scene_light_power(g, only_light(g)) / scene_light_power(p, only_light(p)) -
                     1.0) < 1e-12);
    for (int i = 0; i < 200; i++) {
        double u[3];
        for (int k = 0; k < 3; k++)
            u[k] = rng_uniform(5, (uint64_t)i, 0, (uint32_t)k);
        vec3_t x = vec3_make(6 * u[0] - 3, 4 * u[1] - 1, 6 * u[2] - 3);
        for (double lambda = 385.0; lambda < 720.0; lambda += 55.0) {
            light_sample_t a, b;
            double ea = emission_at(g, x, lambda, &a), eb = emission_at(p, x, lambda, &b);
            assert_true(a.is_delta && a.pdf == 1.0 && fabs(a.dist - b.dist) < 1e-12);
            assert_true(eb > 0.0);
            if (!(fabs(ea / eb - 1.0) < 1e-12))
                fail_msg("at (%g %g %g), %g nm: goniometric %.15g, point %.15g", x.x, x.y, x.z,
                         lambda, ea, eb);
        }
    }
    scene_destroy(&g);
    scene_destroy(&p);
    /* "power": the power whatever the image. */
    img = write_pfm("rings.pfm", 32, 32, rings);
    snprintf(lines, sizeof lines,
             "LightSource \"goniometric\" \"string filename\" \"%s\" \"float power\" 10", img);
    g = load_with_floor(lines, NULL);
    assert_true(fabs(scene_light_power(g, only_light(g)) / 10.0 - 1.0) < 1e-9);
    scene_destroy(&g);
}

/* An image bright only where light-space z > 0: pbrt-v4 maps light space to the CTM with y
 * and z swapped, so a light at the origin lights the plane y = +1 above it and leaves y = -1
 * below it black, in next-event estimation and in the photon pass alike. */
static void test_goniometric_one_hemisphere(void **state)
{
    (void)state;
    const char *img = write_pfm("upper.pfm", 32, 32, upper_half);
    char text[2048];
    snprintf(text, sizeof text,
             "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n"
             "LightSource \"goniometric\" \"string filename\" \"%s\"\n"
             "Material \"diffuse\"\n"
             "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"
             "  \"point3 P\" [-2 1 -2  2 1 -2  2 1 2  -2 1 2]\n"
             "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"
             "  \"point3 P\" [-2 -1 -2  2 -1 -2  2 -1 2  -2 -1 2]\n",
             img);
    scene_t *s = sb_load_text(text, NULL);
    for (int i = 0; i < 100; i++) {
        double a = 1.6 * rng_uniform(6, (uint64_t)i, 0, 0) - 0.8,
               b = 1.6 * rng_uniform(6, (uint64_t)i, 0, 1) - 0.8;
        light_sample_t ls;
        assert_true(emission_at(s, vec3_make(a, 1, b), 550.0, &ls) > 0.0);
        assert_true(emission_at(s, vec3_make(a, -1, b), 550.0, &ls) == 0.0);
    }
    err_t err;
    photon_store_t *m = photon_store_new(s, &err);
    assert_non_null(m);
    photon_job_t job = {
        .seed = 3, .maxdepth = 0, .mindepth = 0, .monochromerays = 1, .policy = PHOTON_STORE_ALL};
    photon_stats_t st = {0};
    assert_int_equal(photon_trace(s, &job, 0, 20000, m, &st, &err), 0);
    assert_int_equal(st.nonfinite, 0);
    const photon_map_t *pm = photon_store_map(m);
    size_t up = 0, down = 0;
    for (size_t i = 0; i < photon_map_count(pm); i++)
        *(photon_map_photon(pm, i).p.y > 0 ? &up : &down) += 1;
    print_message("goniometric upper-half image: %zu photons above, %zu below\n", up, down);
    assert_true(up > 5000);
    assert_int_equal(down, 0);
    photon_store_destroy(&m);
    scene_destroy(&s);
}

/* A projection light of fov 40 degrees and a 4x2 white image at the origin, looking along +z:
 * on the plane z = d its light covers [-X d, X d] x [-Y d, Y d], Y = tan 20 degrees (the shorter
 * axis spans the fov) and X = 2 Y, and nothing outside; a 2x2 image lit only in its top-left
 * texel lands at -x, +y (pbrt-v4 flips y so that the image is upright, and its columns run
 * along +x). */
static void test_projection_footprint(void **state)
{
    (void)state;
    const char *img = write_pfm("wide.pfm", 4, 2, white);
    char lines[1024];
    snprintf(lines, sizeof lines,
             "AttributeBegin\nTranslate 0 0 -1\n"
             "LightSource \"projection\" \"string filename\" \"%s\" \"float fov\" 40\nAttributeEnd",
             img);
    scene_t *s = load_with_floor(lines, NULL);
    assert_int_equal(only_light(s)->kind, LIGHT_PROJECTION);
    const double Y = tan(20.0 * PI / 180.0), X = 2.0 * Y, d = 3.0;
    for (int cx = -1; cx <= 1; cx += 2)
        for (int cy = -1; cy <= 1; cy += 2) {
            light_sample_t ls;
            vec3_t in = vec3_make(0.99 * cx * X * d, 0.99 * cy * Y * d, d - 1.0);
            vec3_t out_x = vec3_make(1.01 * cx * X * d, 0.99 * cy * Y * d, d - 1.0);
            vec3_t out_y = vec3_make(0.99 * cx * X * d, 1.01 * cy * Y * d, d - 1.0);
            double e = emission_at(s, in, 550.0, &ls);
            /* a white texel: the light's D65 at unit scale over d^2 / cos^2 */
            double dist2 =
                vec3_dot(vec3_sub(in, vec3_make(0, 0, -1)), vec3_sub(in, vec3_make(0, 0, -1)));
            assert_true(fabs(e * dist2 / lights_value(only_light(s), 550.0) - 1.0) < 1e-9);
            assert_true(emission_at(s, out_x, 550.0, &ls) == 0.0);
            assert_true(emission_at(s, out_y, 550.0, &ls) == 0.0);
        }
    light_sample_t ls;
    assert_true(emission_at(s, vec3_make(0, 0, -2), 550.0, &ls) == 0.0); /* behind it */
    scene_destroy(&s);

    img = write_pfm("corner.pfm", 2, 2, top_left_only);
    snprintf(lines, sizeof lines,
             "LightSource \"projection\" \"string filename\" \"%s\" \"float fov\" 60", img);
    s = load_with_floor(lines, NULL);
    const double t = tan(30.0 * PI / 180.0);
    assert_true(emission_at(s, vec3_make(-0.5 * t * d, 0.5 * t * d, d), 550.0, &ls) > 0.0);
    assert_true(emission_at(s, vec3_make(0.5 * t * d, 0.5 * t * d, d), 550.0, &ls) == 0.0);
    assert_true(emission_at(s, vec3_make(-0.5 * t * d, -0.5 * t * d, d), 550.0, &ls) == 0.0);
    assert_true(emission_at(s, vec3_make(0.5 * t * d, -0.5 * t * d, d), 550.0, &ls) == 0.0);
    scene_destroy(&s);
}

/* pbrt-v4 ProjectionLight::Create's "power": scale *= power / k_e, k_e = A / N times the sum
 * over the N texels of Y(rgb) cos^3 theta at the texel centre, A = 4 tan^2(fov / 2) aspect. The
 * light's power is then P; k_e is computed here from the formula, with the sRGB luminance
 * row (0.2126, 0.7152, 0.0722). For a white image k_e is the frustum's solid angle
 * 4 asin(X Y / sqrt((1 + X^2)(1 + Y^2))) to the midpoint rule's accuracy. */
static void test_projection_power(void **state)
{
    (void)state;
    const int w = 5, h = 3;
    const double fov = 50.0;
    const char *img = write_pfm("colours.pfm", w, h, colours);
    char lines[1024];
    snprintf(lines, sizeof lines,
             "LightSource \"projection\" \"string filename\" \"%s\" \"float fov\" %g", img, fov);
    scene_t *s = load_with_floor(lines, NULL);
    double tn = tan(0.5 * fov * PI / 180.0), aspect = (double)w / h;
    double X = aspect * tn, Y = tn, sum = 0.0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float c[3];
            colours(x, y, w, h, c);
            double px = (2.0 * (x + 0.5) / w - 1.0) * X, py = (2.0 * (y + 0.5) / h - 1.0) * Y;
            double cos_t = 1.0 / sqrt(1.0 + px * px + py * py);
            sum += (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]) * pow(cos_t, 3);
        }
    double k_e = 4.0 * X * Y * sum / (w * h);
    double got = projmap_power(only_light(s)->projmap);
    print_message("projection k_e %.6f, pbrt-v4's formula %.6f\n", got, k_e);
    assert_true(fabs(got / k_e - 1.0) < 2e-4);
    assert_true(fabs(scene_light_power(s, only_light(s)) / k_e - 1.0) < 2e-4);
    scene_destroy(&s);
    snprintf(
        lines, sizeof lines,
        "LightSource \"projection\" \"string filename\" \"%s\" \"float fov\" %g \"float power\" 7",
        img, fov);
    s = load_with_floor(lines, NULL);
    assert_true(fabs(scene_light_power(s, only_light(s)) / 7.0 - 1.0) < 1e-9);
    scene_destroy(&s);
    /* A white image: the frustum's solid angle. */
    img = write_pfm("white.pfm", 64, 32, white);
    snprintf(lines, sizeof lines,
             "LightSource \"projection\" \"string filename\" \"%s\" \"float fov\" 70", img);
    s = load_with_floor(lines, NULL);
    tn = tan(35.0 * PI / 180.0);
    double omega = 4.0 * asin(2 * tn * tn / sqrt((1 + 4 * tn * tn) * (1 + tn * tn)));
    assert_true(fabs(projmap_solid_angle(only_light(s)->projmap) / omega - 1.0) < 1e-12);
    print_message("white 64x32 image: k_e %.6f, frustum solid angle %.6f\n",
                  projmap_power(only_light(s)->projmap), omega);
    assert_true(fabs(projmap_power(only_light(s)->projmap) / omega - 1.0) < 1e-3);
    scene_destroy(&s);
}

/* The photon pass against next-event estimation on the floor y = 0: photons of a light (the
 * thesis's store with mindepth 0 and maxdepth 0: every photon is deposited where it first lands
 * and ends there) carry, in each of 3x3 blocks of the floor, the energy
 *   integral over lambda and the block of I(w, lambda) cos(theta) / d^2,
 * which is integrated here by the midpoint rule from lights_sample_emission_of. Each photon is
 * deposited at most once, so a block's estimate is a mean of N independent values and its
 * standard error comes from their second moment. */
static void photons_match_nee(const char *light_lines, const char *what)
{
    scene_t *s = load_with_floor(light_lines, NULL);
    const double lo = 380.0, hi = 720.0, half = 3.0;
    const int B = 3, G = 240, NL = 68; /* D65's 5 nm bins: exact for its linear pieces */
    double nee[3][3] = {{0}};
    for (int i = 0; i < G; i++)
        for (int k = 0; k < G; k++) {
            vec3_t x =
                vec3_make(-half + 2 * half * (i + 0.5) / G, 0.0, -half + 2 * half * (k + 0.5) / G);
            light_sample_t ls;
            double e = 0.0;
            for (int j = 0; j < NL; j++) {
                double lambda = lo + (hi - lo) * (j + 0.5) / NL;
                e += emission_at(s, x, lambda, &ls) * (hi - lo) / NL;
            }
            if (e > 0.0)
                nee[i * B / G][k * B / G] += e * fabs(ls.wi.y) * pow(2 * half / G, 2);
        }
    err_t err;
    photon_store_t *m = photon_store_new(s, &err);
    assert_non_null(m);
    const uint64_t N = 150000;
    photon_job_t job = {
        .seed = 9, .maxdepth = 0, .mindepth = 0, .monochromerays = 1, .policy = PHOTON_STORE_ALL};
    photon_stats_t st = {0};
    assert_int_equal(photon_trace(s, &job, 0, N, m, &st, &err), 0);
    assert_int_equal(st.nonfinite, 0);
    const photon_map_t *pm = photon_store_map(m);
    double sum[3][3] = {{0}}, sq[3][3] = {{0}}, total_nee = 0, total = 0;
    for (size_t i = 0; i < photon_map_count(pm); i++) {
        photon_info_t ph = photon_map_photon(pm, i);
        int bi = (int)((ph.p.x + half) / (2 * half) * B),
            bk = (int)((ph.p.z + half) / (2 * half) * B);
        bi = bi < 0 ? 0 : bi >= B ? B - 1 : bi;
        bk = bk < 0 ? 0 : bk >= B ? B - 1 : bk;
        sum[bi][bk] += ph.power;
        sq[bi][bk] += ph.power * ph.power;
    }
    for (int i = 0; i < B; i++)
        for (int k = 0; k < B; k++) {
            double mean = sum[i][k] / N, se = sqrt(fmax(0.0, sq[i][k] / N - mean * mean) / N);
            total += mean;
            total_nee += nee[i][k];
            print_message("%s block (%d, %d): photons %.5f +- %.5f, next-event %.5f\n", what, i, k,
                          mean, se, nee[i][k]);
            /* 4 standard errors, and 1% for the midpoint rule at the image's sharp edges */
            if (!(fabs(mean - nee[i][k]) <= 4.0 * se + 0.01 * nee[i][k] + 1e-9))
                fail_msg("%s block (%d, %d): photons %g +- %g, next-event %g", what, i, k, mean, se,
                         nee[i][k]);
        }
    assert_true(total_nee > 0.0);
    print_message("%s: floor receives %.5f (photons), %.5f (next-event)\n", what, total, total_nee);
    photon_store_destroy(&m);
    scene_destroy(&s);
}

static void test_photons_match_nee(void **state)
{
    (void)state;
    char lines[1024];
    const char *img = write_pfm("rings_nee.pfm", 48, 48, rings);
    snprintf(
        lines, sizeof lines,
        "AttributeBegin\nTranslate 0.4 1 0.2\nRotate 20 0 0 1\n"
        "LightSource \"goniometric\" \"string filename\" \"%s\" \"float power\" 20\nAttributeEnd",
        img);
    photons_match_nee(lines, "goniometric");
    img = write_pfm("colours_nee.pfm", 7, 4, colours);
    snprintf(
        lines, sizeof lines,
        "AttributeBegin\nTranslate -0.3 1.5 0.1\nRotate 80 1 0 0\nRotate 10 0 1 0\n"
        "LightSource \"projection\" \"string filename\" \"%s\" \"float fov\" 60 \"float power\" 5\n"
        "AttributeEnd",
        img);
    photons_match_nee(lines, "projection");
}

/* Black images: a goniometric or projection light of zeros has power 0, lights nothing and
 * renders without a NaN; "power" cannot be met by it and says so. A non-square goniometric
 * image is refused (pbrt-v4 too). */
static void test_black_images(void **state)
{
    (void)state;
    const char *img = write_pfm("black.pfm", 8, 8, black);
    const char *kinds[2] = {"goniometric", "projection"};
    for (int k = 0; k < 2; k++) {
        char lines[1024];
        snprintf(lines, sizeof lines,
                 "AttributeBegin\nTranslate 0 1 0\nRotate 90 1 0 0\n"
                 "LightSource \"%s\" \"string filename\" \"%s\"\nAttributeEnd",
                 kinds[k], img);
        scene_t *s = load_with_floor(lines, NULL);
        assert_true(scene_light_power(s, only_light(s)) == 0.0);
        light_sample_t ls;
        assert_true(emission_at(s, vec3_make(0.1, 0, 0.2), 550.0, &ls) == 0.0);
        sb_image_stats_t st = sb_render_stats(s, 8, 4); /* asserts no non-finite sample */
        assert_true(st.mean == 0.0);
        err_t err;
        photon_store_t *m = photon_store_new(s, &err);
        photon_job_t job = {.seed = 1,
                            .maxdepth = 0,
                            .mindepth = 0,
                            .monochromerays = 4,
                            .policy = PHOTON_STORE_ALL};
        photon_stats_t pst = {0};
        assert_int_equal(photon_trace(s, &job, 0, 2000, m, &pst, &err), 0);
        assert_int_equal(pst.nonfinite, 0);
        assert_true(photon_store_power_sum(m) == 0.0);
        photon_store_destroy(&m);
        scene_destroy(&s);
        snprintf(lines, sizeof lines,
                 "LightSource \"%s\" \"string filename\" \"%s\" \"float power\" 3", kinds[k], img);
        assert_null(load_with_floor(lines, &err));
        assert_non_null(strstr(err.msg, "cannot be met by a black image"));
    }
    img = write_pfm("oblong.pfm", 8, 4, white);
    char lines[1024];
    snprintf(lines, sizeof lines, "LightSource \"goniometric\" \"string filename\" \"%s\"", img);
    err_t err;
    assert_null(load_with_floor(lines, &err));
    assert_non_null(strstr(err.msg, "t.pbrt:5:"));
    assert_non_null(strstr(err.msg, "8x4, not square"));
}

/* Grey, but for a negative green at texel (2, 1) (top row 0). */
static void one_negative(int x, int y, int w, int h, float rgb[3])
{
    grey_quarter(x, y, w, h, rgb);
    if (x == 2 && y == 1)
        rgb[1] = -0.5f;
}

/* Near FLT_MAX, finite: a float sum of the three channels would overflow. */
static void huge_grey(int x, int y, int w, int h, float rgb[3])
{
    (void)x, (void)y, (void)w, (void)h;
    rgb[0] = rgb[1] = rgb[2] = 3e38f;
}

/* A goniometric texel's channel average of finite channels is finite: an image of 3e38 in
 * every channel is a light (its sum in float, 9e38, was infinite and refused as such). */
static void test_goniometric_huge_texels(void **state)
{
    (void)state;
    const char *img = write_pfm("huge.pfm", 4, 4, huge_grey);
    char lines[1024];
    snprintf(lines, sizeof lines, "LightSource \"goniometric\" \"string filename\" \"%s\"", img);
    err_t err = {{0}};
    scene_t *s = load_with_floor(lines, &err);
    if (!s)
        fail_msg("refused: %s", err.msg);
    const light_t *l = only_light(s);
    assert_true(fabs(envmap_mean_luminance(l->gonio) / 3e38 - 1.0) < 1e-6);
    scene_destroy(&s);
}

/* Every light's image obeys one rule (envmap_check_texels): a negative texel is refused with
 * the directive's file and line, the image and the texel -- by a goniometric, a projection
 * and an area light alike. */
static void test_bad_texel_refused(void **state)
{
    (void)state;
    const char *img = write_pfm("one_negative.pfm", 4, 4, one_negative);
    char lines[3][1024];
    snprintf(lines[0], sizeof lines[0], "LightSource \"goniometric\" \"string filename\" \"%s\"",
             img);
    snprintf(lines[1], sizeof lines[1], "LightSource \"projection\" \"string filename\" \"%s\"",
             img);
    snprintf(lines[2], sizeof lines[2],
             "AreaLightSource \"diffuse\" \"string filename\" \"%s\"\n"
             "Shape \"sphere\" \"float radius\" 0.5",
             img);
    for (int k = 0; k < 3; k++) {
        err_t err = {{0}};
        assert_null(load_with_floor(lines[k], &err));
        assert_non_null(strstr(err.msg, "t.pbrt:5:"));
        assert_non_null(strstr(err.msg, "one_negative.pfm"));
        assert_non_null(strstr(err.msg, "texel (2, 1) has a negative value -0.5"));
    }
}

/* ---- image area lights (pbrt-v4 DiffuseAreaLight with "filename") ---- */

static void two_colours(int x, int y, int w, int h, float rgb[3])
{
    (void)y, (void)h;
    static const float left[3] = {1.0f, 0.2f, 0.1f}, right[3] = {0.1f, 0.3f, 1.0f};
    const float *c = x < w / 2 ? left : right;
    rgb[0] = c[0], rgb[1] = c[1], rgb[2] = c[2];
}

static void grey_half(int x, int y, int w, int h, float rgb[3])
{
    (void)x, (void)y, (void)w, (void)h;
    rgb[0] = rgb[1] = rgb[2] = 0.5f;
}

/* A quad x, z in [-1, 1] at height 1.5 facing down, uv = ((x + 1) / 2, (z + 1) / 2). */
#define DOWN_QUAD                                                                                  \
    "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"                                   \
    "  \"point3 P\" [-1 1.5 -1  1 1.5 -1  1 1.5 1  -1 1.5 1]\n"                                    \
    "  \"point2 uv\" [0 0  1 0  1 1  0 1]\n"

static scene_t *load_area(const char *params, const char *shape)
{
    char lines[2048];
    snprintf(lines, sizeof lines, "AttributeBegin\nAreaLightSource \"diffuse\" %s\n%sAttributeEnd",
             params, shape);
    return load_with_floor(lines, NULL);
}

/* A light sample's texture coordinates are those scene_surface gives a hit there: a mesh's
 * interpolated uv, a sphere's (phi / 2 pi, 1 - theta / pi), a disk's (phi / 2 pi, 1 - rho / r);
 * its radiance is the image's there: a grey image of 0.5 at scale 2 is exactly D65 at scale 1,
 * the left (red) half of the image is redder than the right (blue) half; one-sided, nothing
 * arrives from behind; "power" P (and twosided) gives power P with pbrt-v4's k_e = mean(Y) pi A
 * (2 pi A). */
static void test_area_image_lookup(void **state)
{
    (void)state;
    char params[1024];
    const char *img = write_pfm("two.pfm", 4, 2, two_colours);
    snprintf(params, sizeof params, "\"string filename\" \"%s\"", img);
    scene_t *s = load_area(params, DOWN_QUAD);
    const light_t *l = only_light(s);
    assert_non_null(l->area_image);
    int red = 0, blue = 0;
    for (int i = 0; i < 400; i++) {
        double u[4];
        for (int k = 0; k < 4; k++)
            u[k] = rng_uniform(8, (uint64_t)i, 0, (uint32_t)k);
        light_sample_t ls;
        vec3_t x = vec3_make(0.3, 0.0, -0.2);
        assert_true(lights_sample(s, &(lights_at_t){x, {0, 0, 0}, 0}, u, &ls));
        assert_true(fabs(ls.uv[0] - (ls.p_light.x + 1) / 2) < 1e-9);
        assert_true(fabs(ls.uv[1] - (ls.p_light.z + 1) / 2) < 1e-9);
        double e450 = lights_sample_emission_of(s, &ls, lights_value(l, 450.0), 450.0);
        double e650 = lights_sample_emission_of(s, &ls, lights_value(l, 650.0), 650.0);
        assert_true(e450 > 0.0 && e650 > 0.0);
        if (ls.p_light.x < -0.6) { /* more than half a texel inside the left half */
            red++;
            assert_true(e650 / lights_value(l, 650.0) > 2.0 * e450 / lights_value(l, 450.0));
        } else if (ls.p_light.x > 0.6) {
            blue++;
            assert_true(e450 / lights_value(l, 450.0) > 2.0 * e650 / lights_value(l, 650.0));
        }
        /* from above (behind the one-sided light) nothing: the light BVH sees that the light
         * cannot reach there and samples nothing, the other samplers a point that emits 0 */
        if (lights_sample(s, &(lights_at_t){vec3_make(0.1, 3.0, 0.2), {0, 0, 0}, 0}, u, &ls))
            assert_true(lights_sample_emission_of(s, &ls, lights_value(l, 550.0), 550.0) == 0.0);
    }
    assert_true(red > 50 && blue > 50);
    scene_destroy(&s);

    /* power, one- and two-sided: k_e = mean(Y) pi A, Y with the sRGB luminance row */
    const double mean_y = 0.5 * (0.2126 * 1.0 + 0.7152 * 0.2 + 0.0722 * 0.1) +
                          0.5 * (0.2126 * 0.1 + 0.7152 * 0.3 + 0.0722 * 1.0);
    snprintf(params, sizeof params, "\"string filename\" \"%s\" \"float scale\" 3", img);
    s = load_area(params, DOWN_QUAD);
    assert_true(fabs(scene_light_power(s, only_light(s)) / (3.0 * mean_y * PI * 4.0) - 1.0) < 2e-4);
    scene_destroy(&s);
    for (int two = 0; two < 2; two++) {
        snprintf(params, sizeof params,
                 "\"string filename\" \"%s\" \"float power\" 6 \"bool twosided\" %s", img,
                 two ? "true" : "false");
        s = load_area(params, DOWN_QUAD);
        /* pbrt-v4 gives each of the quad's two triangles the power: 12 in all */
        assert_true(fabs(scene_light_power(s, only_light(s)) / 12.0 - 1.0) < 1e-9);
        scene_destroy(&s);
    }

    /* sphere and disk: their (u, v) */
    const char *shapes[2] = {
        "Translate 0.2 1.5 -0.1\nRotate 30 1 0 0\nShape \"sphere\" \"float radius\" 0.4\n",
        "Translate 0.2 1.5 -0.1\nRotate 90 1 0 0\nShape \"disk\" \"float radius\" 0.6\n"};
    for (int k = 0; k < 2; k++) {
        snprintf(params, sizeof params, "\"string filename\" \"%s\" \"bool twosided\" true", img);
        s = load_area(params, shapes[k]);
        transform_t rot;
        assert_int_equal(transform_rotate(k ? 90.0 : 30.0, vec3_make(1, 0, 0), &rot, NULL), 0);
        transform_t to_world =
            transform_compose(transform_translate(vec3_make(0.2, 1.5, -0.1)), rot);
        transform_t from_world = transform_inverse(to_world);
        for (int i = 0; i < 200; i++) {
            double u[4];
            for (int j = 0; j < 4; j++)
                u[j] = rng_uniform(10, (uint64_t)i, (uint32_t)k, (uint32_t)j);
            light_sample_t ls;
            if (!lights_sample(s, &(lights_at_t){vec3_make(0.5, 0.0, 0.3), {0, 0, 0}, 0}, u, &ls))
                continue;
            vec3_t q = transform_point(&from_world, ls.p_light);
            double phi = atan2(q.y, q.x);
            phi += phi < 0 ? 2 * PI : 0;
            double v = k == 0 ? 1.0 - acos(fmax(-1, fmin(1, q.z / 0.4))) / PI
                              : 1.0 - sqrt(q.x * q.x + q.y * q.y) / 0.6;
            assert_true(fabs(ls.uv[0] - phi / (2 * PI)) < 1e-9 ||
                        fabs(fabs(ls.uv[0] - phi / (2 * PI)) - 1) < 1e-9);
            assert_true(fabs(ls.uv[1] - v) < 1e-9);
        }
        scene_destroy(&s);
    }
}

/* A grey image of 0.5 at scale 2 is a plain D65 light at scale 1: the same image to the last
 * bit (the camera sees the light through render.c's emission at hits, the floor through light
 * samples, both the image's value at the point), and the same photons. */
static void test_area_image_grey_is_plain(void **state)
{
    (void)state;
    char params[1024];
    const char *img = write_pfm("grey_half.pfm", 4, 4, grey_half);
    snprintf(params, sizeof params,
             "\"string filename\" \"%s\" \"float scale\" 2 \"bool twosided\" true", img);
    scene_t *a = load_area(params, DOWN_QUAD);
    scene_t *b = load_area("\"bool twosided\" true", DOWN_QUAD);
    sb_image_stats_t sa = sb_render_stats(a, 16, 8), sb = sb_render_stats(b, 16, 8);
    print_message("grey image light %.9f, plain light %.9f\n", sa.mean, sb.mean);
    assert_true(sa.mean > 0.0);
    assert_true(sa.mean == sb.mean && sa.max == sb.max);
    scene_destroy(&a);
    scene_destroy(&b);
}

/* The photon pass against a quadrature on the floor under the image quad: the energy on each
 * of 3x3 blocks of the floor, integral over lambda, the block and the light of
 *   L(uv, lambda) cos(theta_light) cos(theta_floor) / d^2,
 * by the midpoint rule on both surfaces (the radiance from lights_area_image at the light
 * cell's uv). */
static void test_area_image_photons(void **state)
{
    (void)state;
    char params[1024];
    const char *img = write_pfm("two_nee.pfm", 4, 2, two_colours);
    snprintf(params, sizeof params, "\"string filename\" \"%s\" \"float power\" 3", img);
    scene_t *s = load_area(params, DOWN_QUAD);
    const light_t *l = only_light(s);
    const double lo = 380.0, hi = 720.0, half = 3.0;
    const int B = 3, G = 30, GL = 32, NL = 68; /* D65's 5 nm bins: exact for its linear pieces */
    double Lsum[32][32] = {{0}}; /* the radiance integrated over lambda, per light cell */
    for (int a = 0; a < GL; a++)
        for (int c = 0; c < GL; c++)
            for (int j = 0; j < NL; j++) {
                double lambda = lo + (hi - lo) * (j + 0.5) / NL;
                Lsum[a][c] += lights_value(l, lambda) *
                              lights_area_image(l, (a + 0.5) / GL, (c + 0.5) / GL, lambda) *
                              (hi - lo) / NL;
            }
    double quad[3][3] = {{0}};
    for (int i = 0; i < G; i++)
        for (int k = 0; k < G; k++) {
            vec3_t x =
                vec3_make(-half + 2 * half * (i + 0.5) / G, 0.0, -half + 2 * half * (k + 0.5) / G);
            double e = 0.0;
            for (int a = 0; a < GL; a++)
                for (int c = 0; c < GL; c++) {
                    vec3_t q = vec3_make(-1 + 2 * (a + 0.5) / GL, 1.5, -1 + 2 * (c + 0.5) / GL);
                    vec3_t d = vec3_sub(q, x);
                    double d2 = vec3_dot(d, d), ct = d.y / sqrt(d2); /* both cosines */
                    e += Lsum[a][c] * ct * ct / d2 * (4.0 / (GL * GL));
                }
            quad[i * B / G][k * B / G] += e * pow(2 * half / G, 2);
        }
    err_t err;
    photon_store_t *m = photon_store_new(s, &err);
    const uint64_t N = 150000;
    photon_job_t job = {
        .seed = 4, .maxdepth = 0, .mindepth = 0, .monochromerays = 1, .policy = PHOTON_STORE_ALL};
    photon_stats_t st = {0};
    assert_int_equal(photon_trace(s, &job, 0, N, m, &st, &err), 0);
    assert_int_equal(st.nonfinite, 0);
    const photon_map_t *pm = photon_store_map(m);
    double sum[3][3] = {{0}}, sq[3][3] = {{0}};
    for (size_t i = 0; i < photon_map_count(pm); i++) {
        photon_info_t ph = photon_map_photon(pm, i);
        if (ph.p.y > 0.5)
            continue;
        int bi = (int)((ph.p.x + half) / (2 * half) * B),
            bk = (int)((ph.p.z + half) / (2 * half) * B);
        bi = bi < 0 ? 0 : bi >= B ? B - 1 : bi;
        bk = bk < 0 ? 0 : bk >= B ? B - 1 : bk;
        sum[bi][bk] += ph.power;
        sq[bi][bk] += ph.power * ph.power;
    }
    for (int i = 0; i < B; i++)
        for (int k = 0; k < B; k++) {
            double mean = sum[i][k] / N, se = sqrt(fmax(0.0, sq[i][k] / N - mean * mean) / N);
            print_message(
                "image area light block (%d, %d): photons %.5f +- %.5f, quadrature %.5f\n", i, k,
                mean, se, quad[i][k]);
            if (!(fabs(mean - quad[i][k]) <= 4.0 * se + 0.01 * quad[i][k]))
                fail_msg("block (%d, %d): photons %g +- %g, quadrature %g", i, k, mean, se,
                         quad[i][k]);
        }
    photon_store_destroy(&m);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_goniometric_constant_is_point),
        cmocka_unit_test(test_goniometric_one_hemisphere),
        cmocka_unit_test(test_projection_footprint),
        cmocka_unit_test(test_projection_power),
        cmocka_unit_test(test_photons_match_nee),
        cmocka_unit_test(test_black_images),
        cmocka_unit_test(test_bad_texel_refused),
        cmocka_unit_test(test_goniometric_huge_texels),
        cmocka_unit_test(test_area_image_lookup),
        cmocka_unit_test(test_area_image_grey_is_plain),
        cmocka_unit_test(test_area_image_photons),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
