/* bench_photons: the photon pass's figures for docs/performance.md (issue 5's benchmarks):
 *   1. photons traced per CPU second of one thread, and per second on every core, on scenes/prism_beam.pbrt at
 *      its own depth (target: over 1 million per core), for 1 and 16 lanes per photon;
 *   2. memory of each store per million photons emitted, and the wire bytes of a batch;
 *   3. the cost of the gather in the camera phase: irradiance queries per second at camera
 *      hits, and the camera pass's time with the photon integrator against plain path at the
 *      same samples.
 * usage: bench_photons [SCENE] [--photons N] [--reps R]
 * Prints Markdown. Times are the median of R repetitions (default 3). */
#include "local_render.h"
#include "photon.h"
#include "render.h"
#include "scene_load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* CPU time of this thread: the single-core figures use it, as it moves much less than
 * wall-clock time when other processes share the cores. */
static double cpu_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static scene_t *load(const char *path, const char *integrator, int xres, int spp)
{
    err_t err;
    scene_overrides_t ov = {.seed = -1, .xres = xres, .yres = xres * 3 / 4, .spp = spp,
                            .integrator = integrator};
    scene_t *s = scene_load_file(path, &ov, &err);
    if (!s) {
        fprintf(stderr, "bench_photons: %s\n", err.msg);
        exit(1);
    }
    return s;
}

/* Photons [0, n) on this thread; returns seconds, fills the store's figures. */
static double trace_once(const scene_t *s, uint64_t n, int lanes, size_t *mem, size_t *wire,
                         photon_stats_t *st)
{
    err_t err;
    photon_job_t job = photon_job_from_settings(&s->settings);
    job.monochromerays = lanes;
    photon_store_t *store = photon_store_new(s, &err);
    if (!store) {
        fprintf(stderr, "bench_photons: %s\n", err.msg);
        exit(1);
    }
    memset(st, 0, sizeof *st);
    double t0 = cpu_s();
    if (photon_trace(s, &job, 0, n, store, st, &err)) {
        fprintf(stderr, "bench_photons: %s\n", err.msg);
        exit(1);
    }
    double t = cpu_s() - t0;
    *mem = photon_store_memory_bytes(store);
    uint8_t *bytes = NULL;
    if (photon_store_encode(store, &bytes, wire, &err))
        *wire = 0;
    free(bytes);
    photon_store_destroy(&store);
    return t;
}

static double render_once(const scene_t *s, render_stats_t *st)
{
    err_t err;
    tilebuf_t *img = tilebuf_new(0, 0, s->settings.xres, s->settings.yres, s->settings.grid.n, &err);
    local_render_opts_t o = {.threads = 0};
    memset(st, 0, sizeof *st);
    double t0 = now_s();
    if (!img || local_render(s, &o, img, st, &err)) {
        fprintf(stderr, "bench_photons: %s\n", err.msg);
        exit(1);
    }
    double t = now_s() - t0;
    tilebuf_destroy(&img);
    return t;
}

int main(int argc, char **argv)
{
    const char *path = NULL;
    uint64_t photons = 400000;
    int reps = 3;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--photons") && i + 1 < argc)
            photons = strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (argv[i][0] != '-' && !path)
            path = argv[i];
        else {
            fprintf(stderr, "usage: bench_photons [SCENE] [--photons N] [--reps R]\n");
            return 2;
        }
    }
    if (!path)
        path = PRISMFARM_SOURCE_DIR "/scenes/prism_beam.pbrt";
    if (photons < 1000 || reps < 1 || reps > 50) {
        fprintf(stderr, "bench_photons: --photons must be >= 1000 and --reps in 1..50\n");
        return 2;
    }
    int cores = local_render_cores();
    scene_t *s = load(path, NULL, 160, 8);
    if (!s->settings.photon.enabled) {
        fprintf(stderr, "bench_photons: %s has no photon integrator\n", path);
        return 1;
    }
    printf("Scene %s, photon maxdepth %d, %d buckets, %d cores; median of %d runs.\n\n", path,
           s->settings.photon.maxdepth, s->settings.grid.n, cores, reps);
    printf("| lanes per photon | photons | CPU s (1 thread) | photons/s per core | rays/photon | stored per M emitted | store MB per M emitted | wire MB per M emitted |\n");
    printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    const int lanes_list[] = {1, 16};
    for (int li = 0; li < 2; li++) {
        int lanes = lanes_list[li];
        uint64_t n = photons / (uint64_t)lanes;
        double t[50];
        size_t mem = 0, wire = 0;
        photon_stats_t st;
        for (int r = 0; r < reps; r++)
            t[r] = trace_once(s, n, lanes, &mem, &wire, &st);
        double tm = median(t, reps);
        double per_m = 1e6 / (double)st.emitted;
        printf("| %d | %llu | %.3f | %.3g | %.2f | %.0f | %.2f | %.2f |\n", lanes,
               (unsigned long long)n, tm, (double)n / tm, (double)st.rays / (double)n,
               (double)st.deposited * per_m, (double)mem * per_m / 1e6, (double)wire * per_m / 1e6);
    }
    /* Every core: the local pass (threads over contiguous ranges). */
    {
        double t[50];
        err_t err;
        s->settings.photon.photons = photons * (uint64_t)cores;
        for (int r = 0; r < reps; r++) {
            double sec = 0;
            photon_store_t *st = photon_pass_run(s, 0, NULL, &sec, &err);
            if (!st) {
                fprintf(stderr, "bench_photons: %s\n", err.msg);
                return 1;
            }
            t[r] = sec;
            photon_store_destroy(&st);
        }
        double tm = median(t, reps);
        printf("\nAll %d cores (photon_pass_run, %llu photons, store built): %.3f s, %.3g photons/s "
               "(%.3g per core).\n",
               cores, (unsigned long long)s->settings.photon.photons, tm,
               (double)s->settings.photon.photons / tm,
               (double)s->settings.photon.photons / tm / cores);
    }
    /* The gather's cost: the camera pass with the store against plain path, same samples.
     * The store is traced before the timing (photon_pass_get). */
    {
        s->settings.photon.photons = 1000000;
        err_t err;
        double pass_s = 0;
        photon_stats_t pst;
        if (!photon_pass_get(s, &pst, &pass_s, &err)) {
            fprintf(stderr, "bench_photons: %s\n", err.msg);
            return 1;
        }
        scene_t *p = load(path, "path", 160, 8);
        double tp[50], tq[50];
        render_stats_t a, b;
        for (int r = 0; r < reps; r++) {
            tq[r] = render_once(s, &a);
            tp[r] = render_once(p, &b);
        }
        double mq = median(tq, reps), mp = median(tp, reps);
        printf("\nCamera pass at 160x120, 8 spp on every core: photon integrator (1 M photons, "
               "store traced in %.2f s beforehand) %.3f s, %.2f M rays/s; path %.3f s, %.2f M "
               "rays/s: the gather costs %+.1f %% of the camera pass.\n",
               pass_s, mq, a.rays / mq / 1e6, mp, b.rays / mp / 1e6, 100.0 * (mq / mp - 1.0));
        scene_destroy(&p);
    }
    scene_destroy(&s);
    return 0;
}
