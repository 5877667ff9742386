/* The light samplers (sampling/light_bvh.h, scene/emitters.h, render/lights.h): over a scene
 * with every kind of light (a one-sided quad mesh, a two-sided triangle, a sphere, a disk, a
 * point, a spot, a goniometric and a projection light, a distant and an infinite light) and
 * over thousands of small emissive triangles, the pmf of the chosen emitter sums to 1 from
 * random shading points; the pdf lights_sample reports is, to the last bit, the pdf lights_pdf
 * recomputes for the same light, triangle and point; the BVH gives importance 0 only where an
 * emitter cannot send light (behind a one-sided triangle, outside a spot's cone); "uniform" and
 * "power" give pbrt-v4's pmfs (each mesh triangle one light); and a diffuse floor under four
 * kinds of light renders to the same mean under "bvh", "power" and "uniform". */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "emitters.h"
#include "files_testutil.h"
#include "light_bvh.h"
#include "lights.h"
#include "render.h"
#include "rng.h"
#include "scene_builders.h"

static const light_sampler_kind_t SAMPLERS[3] = {LIGHT_SAMPLER_BVH, LIGHT_SAMPLER_POWER,
                                                 LIGHT_SAMPLER_UNIFORM};

static void write_pfm(const char *path, int w, int h)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fprintf(f, "PF\n%d %d\n-1\n", w, h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float rgb[3] = {0.2f + (float)x / w, 0.5f, 0.3f + (float)y / h};
            assert_int_equal(fwrite(rgb, sizeof(float), 3, f), 3);
        }
    fclose(f);
}

/* Every kind of light over a floor y = 0 (the floor is no light). */
static scene_t *load_all_kinds(void)
{
    const char *gimg = testutil_scratch("gonio.pfm");
    write_pfm(gimg, 8, 8);
    char img[1024];
    snprintf(img, sizeof img, "%s", testutil_scratch("proj.pfm"));
    write_pfm(img, 8, 4);
    char text[8192];
    snprintf(
        text, sizeof text,
        "LookAt 0 3 -3  0 0 0  0 1 0\nCamera \"perspective\"\n"
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n"
        "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"
        "  \"point3 P\" [-1 1.5 -1  1 1.5 -1  1 1.5 1  -1 1.5 1]\nAttributeEnd\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 2 3] \"bool twosided\" true\n"
        "Shape \"trianglemesh\" \"integer indices\" [0 1 2]\n"
        "  \"point3 P\" [2 0.5 0  2.5 0.5 0  2 1.5 0.3]\nAttributeEnd\n"
        "AttributeBegin\nTranslate -2 1 1\nAreaLightSource \"diffuse\" \"rgb L\" [3 3 3]\n"
        "Shape \"sphere\" \"float radius\" 0.25\nAttributeEnd\n"
        "AttributeBegin\nTranslate 0 2 2\nRotate 120 1 0 0\nAreaLightSource \"diffuse\" \"rgb L\" "
        "[2 2 2]\n"
        "Shape \"disk\" \"float radius\" 0.4\nAttributeEnd\n"
        "LightSource \"point\" \"point3 from\" [1 1 -1] \"rgb I\" [2 2 2]\n"
        "LightSource \"spot\" \"point3 from\" [-1 2 -1] \"point3 to\" [-1 0 -1] "
        "\"float coneangle\" 25 \"float conedeltaangle\" 5 \"rgb I\" [9 9 9]\n"
        "AttributeBegin\nTranslate 1.5 1 1.5\n"
        "LightSource \"goniometric\" \"string filename\" \"%s\" \"float scale\" 3\nAttributeEnd\n"
        "AttributeBegin\nTranslate -1.5 2.5 0\nRotate 90 1 0 0\n"
        "LightSource \"projection\" \"string filename\" \"%s\" \"float fov\" 40\nAttributeEnd\n"
        "LightSource \"distant\" \"point3 from\" [0 1 0.3] \"point3 to\" [0 0 0] \"rgb L\" [0.5 "
        "0.5 0.5]\n"
        "LightSource \"infinite\" \"rgb L\" [0.1 0.1 0.1]\n"
        "Material \"diffuse\"\n"
        "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"
        "  \"point3 P\" [-3 0 -3  3 0 -3  3 0 3  -3 0 3]\n",
        gimg, img);
    return sb_load_text(text, NULL);
}

/* The index of the first light of that kind (area lights: on a mesh of ntris triangles, or an
 * analytic shape when ntris is 0). */
static int find_light(const scene_t *s, light_kind_t kind, size_t ntris)
{
    for (size_t i = 0; i < s->nlights; i++) {
        const light_t *l = &s->lights[i];
        if (l->kind != kind)
            continue;
        if (kind == LIGHT_AREA &&
            (s->shapes[l->shape].kind == SHAPE_MESH ? s->shapes[l->shape].ntris : 0) != ntris)
            continue;
        return (int)i;
    }
    fail_msg("no light of kind %d", kind);
    return -1;
}

/* A random shading point in [-3, 3]^3 with a random unit normal, or none (a medium) every
 * fourth time. */
static lights_at_t random_at(uint64_t i)
{
    lights_at_t at;
    at.p = vec3_make(6 * rng_uniform(3, i, 0, 0) - 3, 6 * rng_uniform(3, i, 0, 1) - 3,
                     6 * rng_uniform(3, i, 0, 2) - 3);
    double z = 2 * rng_uniform(3, i, 0, 3) - 1,
           phi = 2 * 3.14159265358979 * rng_uniform(3, i, 0, 4);
    double r = sqrt(fmax(0.0, 1 - z * z));
    at.n = i % 4 == 3 ? vec3_make(0, 0, 0) : vec3_make(r * cos(phi), r * sin(phi), z);
    at.mis = 1;
    return at;
}

/* The pmf of every emitter at `at`, summed. */
static double pmf_sum(const scene_t *s, const lights_at_t *at)
{
    double sum = 0.0;
    for (size_t e = 0; e < s->nemitters; e++) {
        size_t tri;
        int l = emitters_light(s, e, &tri);
        double pmf = lights_pmf(s, at, l, tri);
        assert_true(pmf >= 0.0 && pmf <= 1.0);
        sum += pmf;
    }
    return sum;
}

/* The emitters: each mesh triangle one, any other light one; index and (light, triangle)
 * are inverse. Under every sampler the pmfs sum to 1 from random points (the BVH may find
 * nothing of nonzero importance only where no emitter reaches, never here: the infinite
 * light is always there, and the BVH's share then sums to 0 or 1 - p_inf). */
static void test_pmf_sums_to_one(void **state)
{
    (void)state;
    scene_t *s = load_all_kinds();
    assert_int_equal(s->nlights, 10);
    assert_int_equal(s->nemitters, 2 + 1 + 1 + 1 + 1 + 1 + 1 + 1 + 1 + 1);
    assert_int_equal(s->ninfinite, 2);
    for (size_t e = 0; e < s->nemitters; e++) {
        size_t tri;
        int l = emitters_light(s, e, &tri);
        assert_int_equal(emitters_index(s, l, tri), e);
    }
    for (int k = 0; k < 3; k++) {
        s->settings.light_sampler = SAMPLERS[k];
        int full = 0;
        for (uint64_t i = 0; i < 2000; i++) {
            lights_at_t at = random_at(i);
            double sum = pmf_sum(s, &at);
            double inf = SAMPLERS[k] == LIGHT_SAMPLER_BVH ? 2.0 / 3.0 : 0.0;
            if (fabs(sum - 1.0) < 1e-12)
                full++;
            else
                assert_true(sum >= inf - 1e-12 && sum <= 1.0 + 1e-12);
        }
        /* The BVH may lose a share where a node reaches p but neither child does
         * (test_bvh_many_triangles); "power" and "uniform" never. */
        print_message("sampler %d: pmfs sum to 1 at %d of 2000 points\n", k, full);
        assert_true(SAMPLERS[k] == LIGHT_SAMPLER_BVH ? full > 1000 : full == 2000);
    }
    scene_destroy(&s);
}

/* lights_sample's pdf is lights_pdf's (area and infinite lights) or lights_pmf's (delta
 * lights) for the same light, triangle and point, bit for bit, under every sampler; and the
 * frequency with which each emitter is drawn from one point matches its pmf. */
static void test_sample_pdf_consistent(void **state)
{
    (void)state;
    scene_t *s = load_all_kinds();
    for (int k = 0; k < 3; k++) {
        s->settings.light_sampler = SAMPLERS[k];
        int kinds_seen[8] = {0};
        for (uint64_t i = 0; i < 4000; i++) {
            lights_at_t at = random_at(i / 8);
            double u[4];
            for (int j = 0; j < 4; j++)
                u[j] = rng_uniform(5, i, 1, (uint32_t)j);
            light_sample_t ls;
            if (!lights_sample(s, &at, u, &ls))
                continue;
            const light_t *l = &s->lights[ls.light];
            kinds_seen[l->kind]++;
            double pmf = lights_pmf(s, &at, ls.light, ls.tri);
            assert_true(pmf > 0.0);
            if (ls.is_delta)
                assert_true(ls.pdf == pmf);
            else
                assert_true(ls.pdf ==
                            lights_pdf(s, &at, ls.light, ls.tri, ls.wi, ls.p_light, ls.n_light));
        }
        /* (By power the dim projection light is rarely drawn, and then often misses.) */
        for (int kind = 0; kind < 8; kind++)
            if (kind != LIGHT_COLLIMATED && SAMPLERS[k] != LIGHT_SAMPLER_POWER)
                assert_true(kinds_seen[kind] > 0);
    }
    /* Frequencies from one point with a normal, under the BVH. */
    s->settings.light_sampler = LIGHT_SAMPLER_BVH;
    /* Inside the projection light's frustum, where its samples land. */
    lights_at_t at = {vec3_make(-1.2, 0.2, 0.1), vec3_normalize(vec3_make(0.2, 1, 0.1)), 1};
    enum { N = 200000 };
    double count[16] = {0};
    assert_true(s->nemitters <= 16);
    for (uint64_t i = 0; i < N; i++) {
        double u[4] = {(i + rng_uniform(9, i, 0, 0)) / N, rng_uniform(9, i, 0, 1), 0.5, 0.5};
        light_sample_t ls;
        if (lights_sample(s, &at, u, &ls))
            count[emitters_index(s, ls.light, ls.tri)] += 1.0;
    }
    for (size_t e = 0; e < s->nemitters; e++) {
        size_t tri;
        int l = emitters_light(s, e, &tri);
        double pmf = lights_pmf(s, &at, l, tri);
        /* Stratified u: the count is within a few of N pmf (binomial bound as a ceiling). */
        double sd = sqrt(N * pmf * (1 - pmf)) + 1.0;
        assert_true(fabs(count[e] - N * pmf) < 5 * sd);
    }
    scene_destroy(&s);
}

/* pbrt-v4's "uniform": 1 / (number of lights, each triangle one); "power": the light's power
 * share times the triangle's area share within its mesh; both the same from everywhere. */
static void test_uniform_and_power_pmfs(void **state)
{
    (void)state;
    scene_t *s = load_all_kinds();
    double total = 0.0;
    for (size_t i = 0; i < s->nlights; i++)
        total += scene_light_power(s, &s->lights[i]);
    for (uint64_t i = 0; i < 50; i++) {
        lights_at_t at = random_at(i);
        for (size_t e = 0; e < s->nemitters; e++) {
            size_t tri;
            int l = emitters_light(s, e, &tri);
            s->settings.light_sampler = LIGHT_SAMPLER_UNIFORM;
            assert_true(lights_pmf(s, &at, l, tri) == 1.0 / 11.0);
            s->settings.light_sampler = LIGHT_SAMPLER_POWER;
            double share = scene_light_power(s, &s->lights[l]) / total;
            if (l == find_light(s, LIGHT_AREA, 2))
                share *= 0.5; /* the quad's two triangles of equal area */
            assert_true(fabs(lights_pmf(s, &at, l, tri) / share - 1.0) < 1e-12);
        }
    }
    scene_destroy(&s);
}

/* Importance 0 exactly where nothing can arrive: behind the one-sided quad (above it, y > 1.5)
 * its triangles have pmf 0 and lights_sample never returns them; below it they have pmf > 0;
 * outside the spot's cone the spot has pmf 0, inside it more. The two-sided triangle has
 * pmf > 0 from both sides. */
static void test_zero_only_where_dark(void **state)
{
    (void)state;
    scene_t *s = load_all_kinds();
    s->settings.light_sampler = LIGHT_SAMPLER_BVH;
    const vec3_t up = vec3_make(0, 1, 0);
    const int quad = find_light(s, LIGHT_AREA, 2), tri = find_light(s, LIGHT_AREA, 1);
    const int spot = find_light(s, LIGHT_SPOT, 0);
    /* Beyond the quad's bounding sphere (radius sqrt 2 about its centre): inside it the bounds
     * cannot tell the sides apart. */
    lights_at_t above = {vec3_make(0.2, 3.2, 0.1), up, 1},
                below = {vec3_make(0.2, 0.5, 0.1), up, 1};
    for (size_t t = 0; t < 2; t++) {
        assert_true(lights_pmf(s, &above, quad, t) == 0.0);
        assert_true(lights_pmf(s, &below, quad, t) > 0.0);
    }
    for (uint64_t i = 0; i < 4000; i++) {
        double u[4] = {rng_uniform(4, i, 0, 0), rng_uniform(4, i, 0, 1), 0.5, 0.5};
        light_sample_t ls;
        if (lights_sample(s, &above, u, &ls))
            assert_true(ls.light != quad);
    }
    /* The two-sided triangle at x in [2, 2.5], z about 0: from either side. */
    lights_at_t front = {vec3_make(2.2, 0.8, -2), vec3_make(0, 0, 0), 1};
    lights_at_t back = {vec3_make(2.2, 0.8, 2), vec3_make(0, 0, 0), 1};
    assert_true(lights_pmf(s, &front, tri, 0) > 0.0 && lights_pmf(s, &back, tri, 0) > 0.0);
    /* The spot at (-1, 2, -1) pointing down, total half-angle 25 degrees. */
    lights_at_t in = {vec3_make(-1, 0, -1.5), up, 1}, out = {vec3_make(-1, 0, 0.5), up, 1};
    assert_true(lights_pmf(s, &in, spot, 0) > 0.0);
    assert_true(lights_pmf(s, &out, spot, 0) == 0.0);
    scene_destroy(&s);
}

/* The generic tree over random one-sided triangles (many emitters): its depth stays small, an
 * emitter of pmf 0 at p has p behind or in its plane, draws report light_bvh_pmf's pmf, and
 * pmfs sum to at most 1: less where a node's wider cone reaches p but neither child's does
 * (pbrt-v4's tree loses that share too: a draw there finds nothing, which costs variance,
 * not bias). */
static void test_bvh_many_triangles(void **state)
{
    (void)state;
    enum { N = 5000 };
    light_bounds_t *b = calloc(N, sizeof *b);
    vec3_t(*v)[3] = calloc(N, sizeof *v);
    vec3_t *nrm = calloc(N, sizeof *nrm);
    assert_true(b && v && nrm);
    for (uint64_t i = 0; i < N; i++) {
        vec3_t c = vec3_make(10 * rng_uniform(11, i, 0, 0), 10 * rng_uniform(11, i, 0, 1),
                             10 * rng_uniform(11, i, 0, 2));
        for (int k = 0; k < 3; k++)
            v[i][k] = vec3_add(c, vec3_make(0.1 * rng_uniform(11, i, 1 + k, 0) - 0.05,
                                            0.1 * rng_uniform(11, i, 1 + k, 1) - 0.05,
                                            0.1 * rng_uniform(11, i, 1 + k, 2) - 0.05));
        nrm[i] = vec3_normalize(vec3_cross(vec3_sub(v[i][1], v[i][0]), vec3_sub(v[i][2], v[i][0])));
        b[i].lo = b[i].hi = v[i][0];
        for (int k = 1; k < 3; k++) {
            b[i].lo = vec3_make(fmin(b[i].lo.x, v[i][k].x), fmin(b[i].lo.y, v[i][k].y),
                                fmin(b[i].lo.z, v[i][k].z));
            b[i].hi = vec3_make(fmax(b[i].hi.x, v[i][k].x), fmax(b[i].hi.y, v[i][k].y),
                                fmax(b[i].hi.z, v[i][k].z));
        }
        b[i].w = nrm[i];
        b[i].cos_o = 1.0;
        b[i].cos_e = 0.0;
        b[i].phi = 0.5 + rng_uniform(11, i, 9, 0);
    }
    b[17].phi = 0.0; /* left out */
    err_t err;
    light_bvh_t *bvh = light_bvh_new(b, N, &err);
    assert_non_null(bvh);
    assert_true(light_bvh_depth(bvh) <= 40);
    double total = 0.0;
    for (uint64_t j = 0; j < 200; j++) {
        vec3_t p = vec3_make(14 * rng_uniform(12, j, 0, 0) - 2, 14 * rng_uniform(12, j, 0, 1) - 2,
                             14 * rng_uniform(12, j, 0, 2) - 2);
        vec3_t n = j % 2 ? vec3_make(0, 0, 0) : vec3_normalize(vec3_make(1, 2, 3));
        double sum = 0.0;
        for (size_t i = 0; i < N; i++) {
            double pmf = light_bvh_pmf(bvh, i, p, n);
            sum += pmf;
            if (pmf == 0.0 && i != 17) {
                /* Dark only if p is behind (or in) the plane at every vertex. */
                for (int k = 0; k < 3; k++)
                    assert_true(vec3_dot(nrm[i], vec3_sub(p, v[i][k])) <= 1e-9);
            }
        }
        assert_true(light_bvh_pmf(bvh, 17, p, n) == 0.0);
        assert_true(sum <= 1.0 + 1e-9);
        total += sum;
        for (uint64_t k = 0; k < 20; k++) {
            size_t item;
            double pmf;
            if (!light_bvh_sample(bvh, p, n, rng_uniform(13, j, k, 0), &item, &pmf))
                continue;
            assert_true(item != 17);
            assert_true(pmf == light_bvh_pmf(bvh, item, p, n));
        }
    }
    print_message("mean pmf sum %.4f over 200 points\n", total / 200);
    light_bvh_destroy(&bvh);
    assert_null(bvh);
    free(b);
    free(v);
    free(nrm);
}

/* A mesh light of 4096 small triangles (a tessellated sphere of radius 0.5 above a floor)
 * loaded from text: one emitter per triangle, pmfs sum to at most 1, samples agree with
 * lights_pdf for every triangle drawn, and the scene renders. */
static void test_scene_many_emissive_triangles(void **state)
{
    (void)state;
    enum { NU = 64, NV = 32 };
    size_t cap = 1 << 20;
    char *text = malloc(cap);
    assert_non_null(text);
    size_t len = (size_t)snprintf(
        text, cap,
        "LookAt 0 3 -3  0 0 0  0 1 0\nCamera \"perspective\"\n"
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
        "WorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n"
        "Shape \"trianglemesh\" \"point3 P\" [");
    for (int j = 0; j <= NV; j++)
        for (int i = 0; i < NU; i++) {
            double th = 3.14159265358979 * j / NV, ph = 2 * 3.14159265358979 * i / NU;
            len +=
                (size_t)snprintf(text + len, cap - len, "%.9f %.9f %.9f ", 0.5 * sin(th) * cos(ph),
                                 1.0 + 0.5 * cos(th), 0.5 * sin(th) * sin(ph));
        }
    len += (size_t)snprintf(text + len, cap - len, "] \"integer indices\" [");
    for (int j = 0; j < NV; j++)
        for (int i = 0; i < NU; i++) {
            int a = j * NU + i, b = j * NU + (i + 1) % NU, c = a + NU, d = b + NU;
            len += (size_t)snprintf(text + len, cap - len, "%d %d %d %d %d %d ", a, b, c, b, d, c);
        }
    snprintf(text + len, cap - len,
             "]\nAttributeEnd\nMaterial \"diffuse\"\nShape \"trianglemesh\" \"integer indices\" "
             "[0 1 2 0 2 3] \"point3 P\" [-3 0 -3  3 0 -3  3 0 3  -3 0 3]\n");
    scene_t *s = sb_load_text(text, NULL);
    free(text);
    assert_int_equal(s->nemitters, 2 * NU * NV);
    assert_true(light_bvh_depth(s->light_bvh) <= 40);
    for (int k = 0; k < 3; k++) {
        s->settings.light_sampler = SAMPLERS[k];
        for (uint64_t i = 0; i < 40; i++) {
            lights_at_t at = random_at(i);
            double sum = pmf_sum(s, &at);
            assert_true(sum <= 1.0 + 1e-9);
            for (uint64_t j = 0; j < 50; j++) {
                double u[4];
                for (int q = 0; q < 4; q++)
                    u[q] = rng_uniform(14, i, j, (uint32_t)q);
                light_sample_t ls;
                if (!lights_sample(s, &at, u, &ls))
                    continue;
                assert_true(ls.tri < (size_t)(2 * NU * NV));
                assert_true(ls.pdf ==
                            lights_pdf(s, &at, ls.light, ls.tri, ls.wi, ls.p_light, ls.n_light));
            }
        }
    }
    /* It renders: the lamp lights the floor, and every sample is finite (sb_render_stats). */
    s->settings.light_sampler = LIGHT_SAMPLER_BVH;
    sb_image_stats_t st = sb_render_stats(s, 8, 4);
    assert_true(st.mean > 0.0 && isfinite(st.mean));
    scene_destroy(&s);
}

/* A diffuse floor lit by a quad light, a sphere light, a point light and a spot, rendered with
 * `path` and, through a thin fog, with `volpath` (a scattering point has no normal): the image's
 * mean under "bvh", "power" and "uniform" agrees within the noise (each choice is unbiased; a
 * biased one, such as importance 0 for an emitter that does reach, would show here as a
 * missing light's share). */
static void image_means_agree(const char *head, const char *integrator)
{
    char text[4096];
    snprintf(
        text, sizeof text,
        "LookAt 0 4 -4  0 0 0  0 1 0\n%sCamera \"perspective\" \"float fov\" 50\n"
        "Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\n"
        "Integrator \"%s\" \"integer maxdepth\" 2\nWorldBegin\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [3 3 3]\n"
        "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"
        "  \"point3 P\" [-0.5 1.5 -0.5  0.5 1.5 -0.5  0.5 1.5 0.5  -0.5 1.5 0.5]\nAttributeEnd\n"
        "AttributeBegin\nTranslate 1.5 0.6 1\nAreaLightSource \"diffuse\" \"rgb L\" [2 2 2]\n"
        "Shape \"sphere\" \"float radius\" 0.2\nAttributeEnd\n"
        "LightSource \"point\" \"point3 from\" [-1.5 1 0] \"rgb I\" [1 1 1]\n"
        "LightSource \"spot\" \"point3 from\" [0 2 1.5] \"point3 to\" [0 0 1.5] "
        "\"float coneangle\" 30 \"rgb I\" [4 4 4]\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
        "Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3]\n"
        "  \"point3 P\" [-3 0 -3  3 0 -3  3 0 3  -3 0 3]\n",
        head, integrator);
    double mean[3], se[3];
    for (int k = 0; k < 3; k++) {
        scene_t *s = sb_load_text(text, NULL);
        s->settings.light_sampler = SAMPLERS[k];
        sb_image_stats_t st = sb_render_stats(s, 24, 64);
        mean[k] = st.mean;
        se[k] = st.se;
        print_message("%s, sampler %d: mean %.6f +- %.6f, per-sample variance %.6f\n", integrator,
                      k, st.mean, st.se, st.var);
        scene_destroy(&s);
    }
    for (int k = 1; k < 3; k++)
        assert_true(fabs(mean[k] - mean[0]) < 4.0 * sqrt(se[0] * se[0] + se[k] * se[k]));
}

static void test_image_unbiased(void **state)
{
    (void)state;
    image_means_agree("", "path");
    image_means_agree("MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" "
                      "\"rgb sigma_a\" [0.02 0.02 0.02] \"rgb sigma_s\" [0.1 0.1 0.1]\n"
                      "MediumInterface \"\" \"fog\"\n",
                      "volpath");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pmf_sums_to_one),
        cmocka_unit_test(test_sample_pdf_consistent),
        cmocka_unit_test(test_uniform_and_power_pmfs),
        cmocka_unit_test(test_zero_only_where_dark),
        cmocka_unit_test(test_bvh_many_triangles),
        cmocka_unit_test(test_scene_many_emissive_triangles),
        cmocka_unit_test(test_image_unbiased),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
