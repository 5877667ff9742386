/* bench_light_bvh_walk: the light BVH's cost per draw with thousands of emitters, apart from
 * the rest of a render (bench/many_lights.sh measures whole renders). Builds the tree over the
 * 5120 triangles of bench/many_lights.sh's lamps (64 lamps of 80 triangles, radiances spread
 * over two decades), draws at shading points on the floor (y = 0, normal +y) and takes each
 * draw's pmf again as MIS does for a BSDF-sampled hit (light_bvh_pmf), timing both with the
 * thread's CPU clock (steadier than wall time on a shared machine). Prints ns per draw, per
 * pmf, and the mean of 1 / pmf over the draws (an unbiased estimate of the number of emitters
 * of nonzero importance: a check that a change kept the draws consistent). A benchmark, not a
 * test: it asserts nothing. usage: bench_light_bvh_walk [DRAWS] [REPS] [hot] */
#include "light_bvh.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A small deterministic generator (splitmix64) for the scene and the draws. */
static double next_u(unsigned long long *s)
{
    unsigned long long z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (double)((z ^ (z >> 31)) >> 11) * 0x1p-53;
}

static light_bounds_t tri_bounds(vec3_t a, vec3_t b, vec3_t c, double L)
{
    light_bounds_t lb = {0};
    lb.lo =
        vec3_make(fmin(a.x, fmin(b.x, c.x)), fmin(a.y, fmin(b.y, c.y)), fmin(a.z, fmin(b.z, c.z)));
    lb.hi =
        vec3_make(fmax(a.x, fmax(b.x, c.x)), fmax(a.y, fmax(b.y, c.y)), fmax(a.z, fmax(b.z, c.z)));
    vec3_t n = vec3_cross(vec3_sub(b, a), vec3_sub(c, a));
    double area2 = vec3_length(n);
    lb.w = area2 > 0.0 ? vec3_scale(n, 1.0 / area2) : vec3_make(0, 1, 0);
    lb.phi = L * 0.5 * area2 * 3.14159265358979;
    lb.cos_o = 1.0;
    lb.cos_e = 0.0;
    lb.twosided = 0;
    return lb;
}

int main(int argc, char **argv)
{
    const long draws = argc > 1 ? atol(argv[1]) : 2000000;
    const int reps = argc > 2 ? atoi(argv[2]) : 5;
    /* "hot": every shading point within a 0.5 x 0.5 patch, so that the draws walk the same
     * few paths and find their nodes in cache (against the default's points over the floor). */
    const int hot = argc > 3 && !strcmp(argv[3], "hot");
    enum { LAMPS = 64, NU = 8, NV = 5 };
    light_bounds_t *items = malloc(sizeof *items * LAMPS * NU * NV * 2);
    size_t n = 0;
    unsigned long long rs = 1;
    for (int l = 0; l < LAMPS; l++) {
        const double cx = -8 + 16 * next_u(&rs), cy = 1 + 3 * next_u(&rs),
                     cz = -8 + 16 * next_u(&rs);
        const double r = 0.1 + 0.2 * next_u(&rs), L = pow(10.0, 2.0 * next_u(&rs));
        vec3_t P[(NV + 1) * NU];
        for (int j = 0; j <= NV; j++)
            for (int i = 0; i < NU; i++) {
                const double th = 3.14159265358979 * j / NV, ph = 2 * 3.14159265358979 * i / NU;
                P[j * NU + i] = vec3_make(cx + r * sin(th) * cos(ph), cy + r * cos(th),
                                          cz + r * sin(th) * sin(ph));
            }
        for (int j = 0; j < NV; j++)
            for (int i = 0; i < NU; i++) {
                const int a = j * NU + i, b = j * NU + (i + 1) % NU;
                items[n++] = tri_bounds(P[a], P[b], P[a + NU], L);
                items[n++] = tri_bounds(P[b], P[b + NU], P[a + NU], L);
            }
    }
    err_t err = {0};
    light_bvh_t *bvh = light_bvh_new(items, n, &err);
    if (!bvh) {
        fprintf(stderr, "bench_light_bvh_walk: %s\n", err.msg);
        return 1;
    }
    printf("%zu emitters, depth %d, %ld draws x %d repetitions\n", n, light_bvh_depth(bvh), draws,
           reps);
    double best_s = INFINITY, best_p = INFINITY, inv_sum = 0.0;
    long got = 0;
    for (int k = 0; k < reps; k++) {
        unsigned long long ds = 7;
        size_t *picked = malloc(sizeof *picked * (size_t)draws);
        vec3_t *at = malloc(sizeof *at * (size_t)draws);
        for (long i = 0; i < draws; i++)
            at[i] = hot ? vec3_make(0.5 * next_u(&ds), 0.0, 0.5 * next_u(&ds))
                        : vec3_make(-10 + 20 * next_u(&ds), 0.0, -10 + 20 * next_u(&ds));
        const vec3_t nrm = vec3_make(0, 1, 0);
        double t0 = cpu_now();
        long ok = 0;
        double inv = 0.0;
        for (long i = 0; i < draws; i++) {
            double pmf;
            if (light_bvh_sample(bvh, at[i], nrm, next_u(&ds), &picked[i], &pmf)) {
                ok++;
                inv += 1.0 / pmf;
            } else {
                picked[i] = (size_t)-1;
            }
        }
        double t1 = cpu_now();
        double check = 0.0;
        for (long i = 0; i < draws; i++)
            if (picked[i] != (size_t)-1)
                check += light_bvh_pmf(bvh, picked[i], at[i], nrm);
        double t2 = cpu_now();
        best_s = fmin(best_s, (t1 - t0) / (double)draws);
        best_p = fmin(best_p, (t2 - t1) / (double)draws);
        inv_sum = inv;
        got = ok;
        if (check < 0.0) /* keeps the pmf loop from being optimised away */
            printf("?\n");
        free(picked);
        free(at);
    }
    printf("| emitters | sample ns/draw (best of %d) | pmf ns/draw | mean 1/pmf |\n", reps);
    printf("| --- | --- | --- | --- |\n");
    printf("| %zu | %.1f | %.1f | %.1f |\n", n, 1e9 * best_s, 1e9 * best_p,
           got ? inv_sum / (double)got : 0.0);
    light_bvh_destroy(&bvh);
    free(items);
    return 0;
}
