/* filter: pbrt-v4's pixel filters sampled by importance (sampling/filter.h) and what they do to
 * an image, against numbers that do not come from the code: the moments and densities of the
 * filters' own formulas (box: uniform, variance r^2/3; triangle: the tent's bin masses;
 * gaussian: the truncated, shifted gaussian's variance by erf), the signs of mitchell's and
 * sinc's lobes, mean weight 1 (the weights are f/pdf over the integral of f); then rendered:
 * a sharp edge spread by the filter's CDF, Film iso and exposuretime scaling every sum by
 * iso * t / 100, a crop window bit-identical to the same pixels of the full render, and the
 * warnings pbrt-v4's integrator names give. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "filter.h"
#include "pbrt_parser.h"
#include "render.h"
#include "scene_builders.h"
#include "scene_load.h"
#include "warnings.h"

#define N 200000
#define M_PI 3.14159265358979323846

/* A fixed-seed generator for the tests' uniforms (not the renderer's). */
static double uni(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) * 0x1p-53;
}

static filter_sampler_t *make(filter_kind_t k)
{
    err_t err;
    filter_params_t p = filter_params_default(k);
    filter_sampler_t *f = filter_sampler_new(&p, &err);
    if (!f)
        fail_msg("filter_sampler_new: %s", err.msg);
    return f;
}

static void test_box_uniform(void **state)
{
    (void)state;
    filter_sampler_t *f = make(FILTER_BOX);
    uint64_t s = 1;
    int bins[10] = {0};
    double sum = 0, sq = 0;
    for (int i = 0; i < N; i++) {
        filter_sample_t fs = filter_sampler_sample(f, uni(&s), uni(&s));
        assert_true(fabs(fs.dx) <= 0.5 && fabs(fs.dy) <= 0.5 && fs.weight == 1.0);
        bins[(int)((fs.dx + 0.5) * 10)]++;
        sum += fs.dx;
        sq += fs.dx * fs.dx;
    }
    /* chi-square with 9 degrees of freedom: P(> 27.9) = 0.001 */
    double chi = 0;
    for (int b = 0; b < 10; b++)
        chi += (bins[b] - N / 10.0) * (bins[b] - N / 10.0) / (N / 10.0);
    assert_true(chi < 27.9);
    double var = sq / N - (sum / N) * (sum / N);
    assert_true(fabs(var - 0.25 / 3.0) < 4.0 * 0.0833 * sqrt(0.8 / N)); /* var of x^2: 4r^4/45 */
    filter_sampler_destroy(&f);
}

/* The tent of radius 2: mass of [a, b] on one side = (F(b) - F(a)), F from (r - |x|) / r^2. */
static double tent_cdf(double x, double r)
{
    return x < 0 ? (r + x) * (r + x) / (2 * r * r) : 1.0 - (r - x) * (r - x) / (2 * r * r);
}

static void test_triangle_density(void **state)
{
    (void)state;
    filter_sampler_t *f = make(FILTER_TRIANGLE);
    uint64_t s = 2;
    int bins[16] = {0};
    for (int i = 0; i < N; i++) {
        filter_sample_t fs = filter_sampler_sample(f, uni(&s), uni(&s));
        assert_true(fabs(fs.dx) <= 2.0 && fs.weight == 1.0);
        int b = (int)((fs.dx + 2.0) * 4);
        bins[b < 16 ? b : 15]++;
    }
    double chi = 0;
    for (int b = 0; b < 16; b++) {
        double e = N * (tent_cdf(-2.0 + (b + 1) / 4.0, 2.0) - tent_cdf(-2.0 + b / 4.0, 2.0));
        chi += (bins[b] - e) * (bins[b] - e) / e;
    }
    assert_true(chi < 37.7); /* 15 degrees of freedom, P = 0.001 */
    filter_sampler_destroy(&f);
}

/* pbrt-v4's gaussian: g(x) - g(r) on [-r, r], g of sigma 0.5, r = 1.5. Its variance:
 * (s^2 E - 2 s^2 r g(r) - 2 r^3 g(r) / 3) / (E - 2 r g(r)), E = erf(r / (s sqrt 2)). */
static void test_gaussian_variance(void **state)
{
    (void)state;
    const double sg = 0.5, r = 1.5;
    double gr = exp(-r * r / (2 * sg * sg)) / sqrt(2 * M_PI * sg * sg);
    double E = erf(r / (sg * sqrt(2.0)));
    double expect = (sg * sg * E - 2 * sg * sg * r * gr - 2 * r * r * r * gr / 3) / (E - 2 * r * gr);
    filter_sampler_t *f = make(FILTER_GAUSSIAN);
    uint64_t s = 3;
    double sx = 0, sxx = 0, syy = 0;
    for (int i = 0; i < N; i++) {
        filter_sample_t fs = filter_sampler_sample(f, uni(&s), uni(&s));
        assert_true(fabs(fs.dx) <= r && fabs(fs.dy) <= r);
        assert_true(fabs(fs.weight - 1.0) < 1e-12);
        sx += fs.dx;
        sxx += fs.dx * fs.dx;
        syy += fs.dy * fs.dy;
    }
    /* The table's cells (3/48 wide) add up to h^2/12 = 3e-4; the estimate's own error is
     * about var sqrt(2/N) = 5e-4. */
    double tol = 4.0 * expect * sqrt(2.0 / N) + 4e-4;
    assert_true(fabs(sx / N) < 4.0 * sqrt(expect / N));
    if (!(fabs(sxx / N - expect) < tol && fabs(syy / N - expect) < tol))
        fail_msg("gaussian variance %g, %g; expected %g", sxx / N, syy / N, expect);
    filter_sampler_destroy(&f);
}

/* Mitchell & Netravali's cubic, B = C = 1/3, on [-2, 2] (written out here, not the code's). */
static double mitchell(double x)
{
    const double B = 1.0 / 3, C = 1.0 / 3;
    x = fabs(x);
    if (x < 1)
        return ((12 - 9 * B - 6 * C) * x * x * x + (-18 + 12 * B + 6 * C) * x * x + 6 - 2 * B) / 6;
    if (x < 2)
        return ((-B - 6 * C) * x * x * x + (6 * B + 30 * C) * x * x + (-12 * B - 48 * C) * x + 8 * B + 24 * C) / 6;
    return 0;
}

static double lanczos(double x)
{
    if (fabs(x) > 4)
        return 0;
    double a = x == 0 ? 1 : sin(M_PI * x) / (M_PI * x), b = x == 0 ? 1 : sin(M_PI * x / 3) / (M_PI * x / 3);
    return a * b;
}

/* A separable filter f(x) f(y) of radius r: every sample's weight has f's sign, its size is
 * (integral |f|)^2 / (integral f)^2, and the mean weight is 1. */
static void check_signed(filter_kind_t kind, double (*f1)(double), double r, double scale)
{
    double ia = 0, is = 0;
    const int M = 200000;
    for (int i = 0; i < M; i++) {
        double v = f1(scale * (-r + 2 * r * (i + 0.5) / M));
        ia += fabs(v);
        is += v;
    }
    double w_expect = (ia / is) * (ia / is);
    filter_sampler_t *f = make(kind);
    uint64_t s = 4;
    double wsum = 0;
    int neg = 0;
    for (int i = 0; i < N; i++) {
        filter_sample_t fs = filter_sampler_sample(f, uni(&s), uni(&s));
        double v = f1(scale * fs.dx) * f1(scale * fs.dy);
        /* Only where the sign is clear of the table's cells (1/32 wide) near a zero. */
        if (fabs(v) > 0.02 && (v > 0) != (fs.weight > 0))
            fail_msg("%s: f(%g, %g) = %g but weight %g", filter_kind_name(kind), fs.dx, fs.dy, v, fs.weight);
        if (!(fabs(fabs(fs.weight) - w_expect) < 3e-3 * w_expect))
            fail_msg("%s: |weight| %.6g, expected %.6g", filter_kind_name(kind), fabs(fs.weight), w_expect);
        neg += fs.weight < 0;
        wsum += fs.weight;
    }
    assert_true(neg > N / 100); /* the negative lobes are sampled */
    double se = w_expect / sqrt((double)N);
    if (!(fabs(wsum / N - 1.0) < 4.0 * se))
        fail_msg("%s: mean weight %.6g, expected 1 (se %.3g)", filter_kind_name(kind), wsum / N, se);
    filter_sampler_destroy(&f);
}

static void test_mitchell_sinc_weights(void **state)
{
    (void)state;
    check_signed(FILTER_MITCHELL, mitchell, 2.0, 1.0); /* pbrt-v4: Mitchell1D(2 x / radius) */
    check_signed(FILTER_SINC, lanczos, 4.0, 1.0);
}

/* ---- rendered ---- */

static tilebuf_t *render(scene_t *s)
{
    err_t err;
    const render_settings_t *rs = &s->settings;
    tilebuf_t *t = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    if (!t || render_tile(s, NULL, 0, 0, rs->xres, rs->yres, 0, (uint32_t)rs->spp, t, NULL, &err))
        fail_msg("render: %s", err.msg);
    return t;
}

/* An emitter of luminance 1 filling x < 0 of the view (camera at the origin looking down +z,
 * fov 90: x = 0 is the boundary between columns 3 and 4 of 8). */
static void edge_text(char *buf, size_t n, const char *filter, const char *film)
{
    snprintf(buf, n,
             "Camera \"perspective\" \"float fov\" 90\n"
             "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8 %s\n"
             "Sampler \"stratified\" \"integer xsamples\" 16 \"integer ysamples\" 16\n"
             "%s\nIntegrator \"path\" \"integer maxdepth\" 1\nWorldBegin\n"
             "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n"
             /* The quad reaches +-2, not +-100: Embree's float edge test is exact to about
              * 1e-7 of the vertices' size, and with vertices at 100 a ray 1e-5 past the edge
              * (a camera sample 5e-5 of a pixel into column 4, which the low-discrepancy
              * sampler drew) still hit it, and column 4 was not 0. */
             "Shape \"trianglemesh\" \"point3 P\" [-2 -2 1  0 -2 1  0 2 1  -2 2 1] "
             "\"integer indices\" [0 1 2 0 2 3]\n",
             film, filter);
}

/* Mean Y of column x over the rows, and its standard error from the samples' Y^2. */
static double column(const tilebuf_t *t, int x, double *se)
{
    double y = 0, yy = 0, n = 0;
    for (int r = 0; r < tilebuf_height(t); r++) {
        y += tilebuf_xyz_sum(t, x, r, 1);
        yy += tilebuf_luminance_sq_sum(t, x, r);
        n += (double)tilebuf_count(t, x, r);
    }
    double m = y / n;
    *se = sqrt(fmax(yy / n - m * m, 1e-6) / n);
    return m;
}

static void test_edge_spread(void **state)
{
    (void)state;
    char text[2048];
    /* Box 0.5: the step stays a step (columns 3 | 4 are 1 | 0 up to spectral noise). */
    edge_text(text, sizeof text, "PixelFilter \"box\"", "");
    scene_t *s = sb_load_text(text, NULL);
    tilebuf_t *t = render(s);
    double se, c3 = column(t, 3, &se), c4 = column(t, 4, &se);
    assert_true(fabs(c3 - 1.0) < 0.05 && c4 == 0.0);
    tilebuf_destroy(&t);
    scene_destroy(&s);
    /* pbrt-v4's default gaussian (no PixelFilter line): column 3's centre is half a pixel
     * from the edge, so it reads P(dx < 1/2) of the truncated gaussian, column 4 the rest,
     * column 5 (1.5 away: the radius) nothing. P from erf: (G(1/2) - G(-r) - (1/2 + r) g(r))
     * / (G(r) - G(-r) - 2 r g(r)), G the gaussian's CDF. */
    const double sg = 0.5, r = 1.5;
    double gr = exp(-r * r / (2 * sg * sg)) / sqrt(2 * M_PI * sg * sg);
    double G = 0.5 * (1 + erf(0.5 / (sg * sqrt(2.0)))), Gm = 0.5 * (1 + erf(-r / (sg * sqrt(2.0))));
    double total = erf(r / (sg * sqrt(2.0))) - 2 * r * gr;
    double p = (G - Gm - (0.5 + r) * gr) / total;
    edge_text(text, sizeof text, "", "");
    s = sb_load_text(text, NULL);
    t = render(s);
    double se3, se4;
    c3 = column(t, 3, &se3);
    c4 = column(t, 4, &se4);
    if (!(fabs(c3 - p) < 5 * se3 + 0.01 && fabs(c4 - (1 - p)) < 5 * se4 + 0.01))
        fail_msg("gaussian edge: columns 3, 4 read %g, %g; expected %g, %g (se %g)", c3, c4, p, 1 - p, se3);
    assert_true(column(t, 5, &se) == 0.0 && fabs(column(t, 1, &se) - 1.0) < 0.05);
    tilebuf_destroy(&t);
    scene_destroy(&s);
}

static void compare_scaled(const tilebuf_t *a, const tilebuf_t *b, double k, double tol)
{
    for (int y = 0; y < tilebuf_height(a); y++)
        for (int x = 0; x < tilebuf_width(a); x++) {
            for (int c = 0; c < 3; c++) {
                double va = tilebuf_xyz_sum(a, x, y, c), vb = tilebuf_xyz_sum(b, x, y, c);
                if (!(fabs(vb - k * va) <= tol * fabs(k * va)))
                    fail_msg("pixel (%d, %d) XYZ %d: %.17g, expected %g x %.17g", x, y, c, vb, k, va);
            }
            for (int bk = 0; bk < tilebuf_nbuckets(a); bk++)
                if (!(fabs(tilebuf_sum(b, x, y, bk) - k * tilebuf_sum(a, x, y, bk)) <=
                      tol * fabs(k * tilebuf_sum(a, x, y, bk))))
                    fail_msg("pixel (%d, %d) bucket %d not scaled by %g", x, y, bk, k);
        }
}

static void test_iso_exposure(void **state)
{
    (void)state;
    char text[2048];
    edge_text(text, sizeof text, "", "");
    scene_t *s = sb_load_text(text, NULL);
    tilebuf_t *a = render(s);
    scene_destroy(&s);
    /* 400 x 0.5 / 100 = 2: a power of two scales every sum exactly. */
    edge_text(text, sizeof text, "", "\"float iso\" 400 \"float exposuretime\" 0.5");
    s = sb_load_text(text, NULL);
    assert_true(s->settings.imaging_ratio == 2.0);
    tilebuf_t *b = render(s);
    scene_destroy(&s);
    compare_scaled(a, b, 2.0, 0.0);
    tilebuf_destroy(&b);
    edge_text(text, sizeof text, "", "\"float iso\" 150");
    s = sb_load_text(text, NULL);
    b = render(s);
    scene_destroy(&s);
    compare_scaled(a, b, 1.5, 1e-12);
    tilebuf_destroy(&b);
    /* maxcomponentvalue 0.25: no sample's Y exceeds it (an emitter of Y = 1 seen directly). */
    edge_text(text, sizeof text, "", "\"float maxcomponentvalue\" 0.25");
    s = sb_load_text(text, NULL);
    b = render(s);
    scene_destroy(&s);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 8; x++) {
            double n = (double)tilebuf_count(b, x, y);
            assert_true(tilebuf_luminance_sq_sum(b, x, y) <= n * 0.25 * 0.25 * (1 + 1e-12));
        }
    tilebuf_destroy(&b);
    tilebuf_destroy(&a);
}

static void test_crop_identical(void **state)
{
    (void)state;
    char text[2048];
    edge_text(text, sizeof text, "PixelFilter \"mitchell\"", "");
    scene_t *s = sb_load_text(text, NULL);
    tilebuf_t *full = render(s);
    scene_destroy(&s);
    struct {
        const char *film;
        int x0, y0, w, h;
    } cases[] = {
        /* pbrt-v4: pixels ceil(8 * 0.25) .. ceil(8 * 0.75) by ceil(8 * 0.5) .. 8 */
        {"\"float cropwindow\" [0.25 0.75 0.5 1]", 2, 4, 4, 4},
        {"\"integer pixelbounds\" [3 7 1 2]", 3, 1, 4, 1},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        edge_text(text, sizeof text, "PixelFilter \"mitchell\"", cases[c].film);
        s = sb_load_text(text, NULL);
        assert_int_equal(s->settings.xres, cases[c].w);
        assert_int_equal(s->settings.yres, cases[c].h);
        tilebuf_t *crop = render(s);
        scene_destroy(&s);
        for (int y = 0; y < cases[c].h; y++)
            for (int x = 0; x < cases[c].w; x++) {
                int fx = x + cases[c].x0, fy = y + cases[c].y0;
                assert_true(tilebuf_count(crop, x, y) == tilebuf_count(full, fx, fy));
                for (int k = 0; k < 3; k++)
                    assert_true(tilebuf_xyz_sum(crop, x, y, k) == tilebuf_xyz_sum(full, fx, fy, k));
                for (int b = 0; b < tilebuf_nbuckets(full); b++)
                    assert_true(tilebuf_sum(crop, x, y, b) == tilebuf_sum(full, fx, fy, b));
            }
        tilebuf_destroy(&crop);
    }
    tilebuf_destroy(&full);
}

static void expect_warning(const char *text, const char *expected)
{
    scene_t *s = sb_load_text(text, NULL);
    for (size_t i = 0; i < warnings_count(s->warnings); i++)
        if (!strcmp(warnings_at(s->warnings, i), expected)) {
            scene_destroy(&s);
            return;
        }
    for (size_t i = 0; i < warnings_count(s->warnings); i++)
        print_message("  warning: %s\n", warnings_at(s->warnings, i));
    scene_destroy(&s);
    fail_msg("no warning \"%s\"", expected);
}

#define LIGHT "WorldBegin\nLightSource \"point\"\n"

static void test_pbrt_names_warn(void **state)
{
    (void)state;
    expect_warning("Film \"rgb\"\nIntegrator \"bdpt\" \"integer maxdepth\" 3 \"bool visualizestrategies\" true\n" LIGHT,
                   "t.pbrt:2:1: bdpt is rendered by the path tracer, after a photon pass when the "
                   "plan calls for one (`prismfarm plan` says why): caustics of point, spot, "
                   "distant and small bright lights through smooth glass and mirrors, which only "
                   "bdpt's light paths find, come from photons gathered on the diffuse and glossy "
                   "surfaces that receive them; the rest is the same image with different noise");
    expect_warning("Integrator \"bdpt\" \"bool visualizestrategies\" true\n" LIGHT,
                   "t.pbrt:1:19: \"visualizestrategies\" of Integrator \"bdpt\" is not simulated");
    expect_warning("Integrator \"mlt\" \"integer chains\" 10\n" LIGHT,
                   "t.pbrt:1:18: \"chains\" of Integrator \"mlt\" is not simulated");
    expect_warning("Film \"gbuffer\"\n" LIGHT,
                   "t.pbrt:1:6: Film \"gbuffer\" is rendered as \"rgb\": its albedo, normal and depth "
                   "layers are not written");
    /* volpath without media is path: no warning at all. */
    scene_t *s = sb_load_text(
        "Integrator \"volpath\" \"integer maxdepth\" 7 \"string lightsampler\" \"bvh\"\n" LIGHT, NULL);
    assert_int_equal(warnings_count(s->warnings), 0);
    assert_int_equal(s->settings.integrator, INTEGRATOR_PATH);
    assert_int_equal(s->settings.maxdepth, 7);
    scene_destroy(&s);
    /* sppm: photons = photonsperiteration x pixelsamples, radius kept. */
    s = sb_load_text("Sampler \"halton\" \"integer pixelsamples\" 8\n"
                     "Integrator \"sppm\" \"integer photonsperiteration\" 1000 \"float radius\" 0.25\n" LIGHT,
                     NULL);
    assert_true(s->settings.photon.enabled && s->settings.photon.photons == 8000 &&
                s->settings.photon.radius == 0.25);
    scene_destroy(&s);
}

/* The corpus scene that started this: pbrt-v4's caustic-glass (Film "rgb" "float iso" 150,
 * Integrator "bdpt"). It must pass the Film and Integrator stages. */
static void test_corpus_caustic_glass(void **state)
{
    (void)state;
    const char *path = "../../shared/pbrt-scenes/caustic-glass/caustic-glass-v4.pbrt";
    FILE *f = fopen(path, "r");
    if (!f) {
        print_message("skipped: %s is absent (a clone without ../shared)\n", path);
        skip();
    }
    fclose(f);
    err_t err = {{0}};
    scene_desc_t *d = pbrt_parse_file(path, &err);
    if (!d)
        fail_msg("caustic-glass does not parse: %s", err.msg);
    assert_true(d->film.iso == 150.0);
    scene_overrides_t ov = {.xres = 7, .yres = 10, .spp = 1, .seed = -1};
    scene_t *s = scene_load(d, &ov, &err);
    scene_desc_destroy(&d);
    if (!s)
        fail_msg("caustic-glass does not load: %s", err.msg);
    assert_true(s->settings.imaging_ratio == 1.5);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_uniform),       cmocka_unit_test(test_triangle_density),
        cmocka_unit_test(test_gaussian_variance), cmocka_unit_test(test_mitchell_sinc_weights),
        cmocka_unit_test(test_edge_spread),       cmocka_unit_test(test_iso_exposure),
        cmocka_unit_test(test_crop_identical),    cmocka_unit_test(test_pbrt_names_warn),
        cmocka_unit_test(test_corpus_caustic_glass),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
