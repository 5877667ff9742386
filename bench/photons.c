/* bench_photons: the photon pass's figures for docs/performance.md ("The photon pass"), for
 * each caustic store -- the photon map and light maps at one or more texel densities:
 *   1. photons traced per CPU second of one thread on scenes/prism_beam.pbrt at its own depth
 *      (target: over 1 million per core), for 1 and 16 monochrome rays per photon, and the
 *      store's memory and wire bytes per million photons emitted;
 *   2. the whole local pass on every core (the store built as the camera pass gets it);
 *   3. the cost of the gather in the camera phase: irradiance queries per CPU second at the
 *      diffuse points the camera sees (the photon map's fixed-radius and k-nearest density
 *      estimates against the light map's texel lookup), and the camera pass's CPU time with
 *      each store against plain path tracing at the same samples.
 * usage: bench_photons [SCENE] [--photons N] [--reps R] [--store photonmap|lightmap|both]
 *                      [--density D[,D...]] [--k K]
 * Prints Markdown. Times are the median of R repetitions (default 3); single-thread figures use
 * the thread's CPU time and multi-thread ones the process's as well as wall time, since the
 * machine may be shared: the load average is printed before and after. */
#include "camera.h"
#include "lightmap.h"
#include "clock.h"
#include "local_render.h"
#include "pool.h"
#include "photon_pass.h"
#include "render.h"
#include "scene_load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* CPU time of this thread: the single-core figures use it, as it moves much less than
 * wall-clock time when other processes share the cores. */
static double cpu_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* CPU time of every thread of the process (the multi-thread passes). */
static double proc_cpu_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void loadavg(char *buf, size_t n)
{
    FILE *f = fopen("/proc/loadavg", "r");
    snprintf(buf, n, "unknown");
    if (!f)
        return;
    double a, b, c;
    if (fscanf(f, "%lf %lf %lf", &a, &b, &c) == 3)
        snprintf(buf, n, "%.2f / %.2f / %.2f", a, b, c);
    fclose(f);
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

/* The camera pass's width (height 3/4 of it): twice the scene's test size, so that a pass
 * takes about a CPU second and its timing is steady. */
#define CAM_RES 320

static void die(const char *msg)
{
    fprintf(stderr, "bench_photons: %s\n", msg);
    exit(1);
}

/* A caustic store to measure: its kind, a light map's density, a photon map's k (0: every
 * photon within the radius). */
typedef struct store_cfg {
    photon_store_kind_t kind;
    double density;
    int k;
    char label[64];
} store_cfg_t;

static scene_t *load(const char *path, const char *integrator, int xres, int spp)
{
    err_t err;
    scene_overrides_t ov = {
        .seed = -1, .xres = xres, .yres = xres * 3 / 4, .spp = spp, .integrator = integrator};
    scene_t *s = scene_load_file(path, &ov, &err);
    if (!s)
        die(err.msg);
    return s;
}

static void configure(scene_t *s, const store_cfg_t *c)
{
    s->settings.photon.store = c->kind;
    if (c->kind == PHOTON_STORE_LIGHTMAP)
        s->settings.photon.lightmap_density = c->density;
    s->settings.photon.k = c->k;
}

/* The wire form of a store, finished or not (a finished light map is the same map). */
static size_t wire_bytes(const photon_store_t *store)
{
    err_t err;
    uint8_t *bytes = NULL;
    size_t len = 0;
    int rc = photon_store_finished(store) && photon_store_lightmap(store)
                 ? lightmap_encode(photon_store_lightmap(store), &bytes, &len, &err)
                 : photon_store_encode(store, &bytes, &len, &err);
    free(bytes);
    return rc ? 0 : len;
}

/* Photons [0, n) on this thread into the scene's store; returns CPU seconds, fills the store's
 * figures. */
static double trace_once(const scene_t *s, uint64_t n, int lanes, size_t *mem, size_t *wire,
                         size_t *held, photon_stats_t *st)
{
    err_t err;
    photon_job_t job = photon_job_from_settings(&s->settings);
    job.monochromerays = lanes;
    photon_store_t *store = photon_store_new(s, &err);
    if (!store)
        die(err.msg);
    memset(st, 0, sizeof *st);
    double t0 = cpu_s();
    if (photon_trace(s, &job, 0, n, store, st, &err))
        die(err.msg);
    double t = cpu_s() - t0;
    *mem = photon_store_memory_bytes(store);
    *held = photon_store_count(store);
    *wire = wire_bytes(store);
    photon_store_destroy(&store);
    return t;
}

static void render_once(const scene_t *s, const photon_store_t *photons, render_stats_t *st,
                        double *wall, double *cpu)
{
    err_t err;
    tilebuf_t *img =
        tilebuf_new(0, 0, s->settings.xres, s->settings.yres, s->settings.grid.n, &err);
    local_render_opts_t o = {.threads = 0, .photons = photons};
    memset(st, 0, sizeof *st);
    double t0 = clock_now_s(), c0 = proc_cpu_s();
    if (!img || local_render(s, &o, img, st, NULL, &err))
        die(err.msg);
    *wall = clock_now_s() - t0;
    *cpu = proc_cpu_s() - c0;
    tilebuf_destroy(&img);
}

/* The points the camera pass gathers at first: the first diffuse hit of a ray through each
 * pixel centre (after any mirror or glass the ray meets, straight on; good enough for timing),
 * with the normal on the side the camera sees. */
typedef struct gather_pt {
    hit_t h;
    vec3_t n;
} gather_pt_t;

static size_t gather_points(const scene_t *s, gather_pt_t **out)
{
    int w = s->settings.xres, h = s->settings.yres;
    gather_pt_t *pts = malloc((size_t)w * (size_t)h * sizeof *pts);
    if (!pts)
        die("out of memory");
    size_t n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            vec3_t org, dir;
            camera_ray(&s->camera, w, h, x + 0.5, y + 0.5, 0.5, 0.5, &org, &dir);
            for (int bounce = 0; bounce < 8; bounce++) {
                hit_t hit;
                if (!geometry_intersect(s->geometry, org, dir, 0.0, INFINITY, &hit))
                    break;
                const material_t *m = &s->materials[s->shapes[hit.shape].material];
                if (m->kind == MATERIAL_DIFFUSE) {
                    pts[n].h = hit;
                    pts[n].n = vec3_dot(hit.ng, dir) < 0.0 ? hit.ng : vec3_neg(hit.ng);
                    n++;
                    break;
                }
                org = geometry_offset(hit.p, hit.ng, dir);
            }
        }
    *out = pts;
    return n;
}

/* CPU nanoseconds per photon_store_irradiance at the points (repeated until 0.2 s), and the
 * fraction of points where the store held power. */
static double gather_ns(const photon_store_t *store, const gather_pt_t *pts, size_t n,
                        double *found)
{
    double E[RENDER_MAX_BUCKETS];
    size_t hits = 0, queries = 0;
    double t0 = cpu_s(), t = 0.0;
    do {
        hits = 0;
        for (size_t i = 0; i < n; i++)
            hits += (size_t)photon_store_irradiance(store, &pts[i].h, pts[i].h.p, pts[i].n, E);
        queries += n;
        t = cpu_s() - t0;
    } while (t < 0.2);
    *found = n ? (double)hits / (double)n : 0.0;
    return 1e9 * t / (double)queries;
}

static int parse_densities(const char *arg, double *d, int max)
{
    int n = 0;
    const char *p = arg;
    while (*p && n < max) {
        char *end;
        double v = strtod(p, &end);
        if (end == p || !(v > 0.0 && v <= LIGHTMAP_MAX_DENSITY))
            return -1;
        d[n++] = v;
        p = *end == ',' ? end + 1 : end;
        if (*end && *end != ',')
            return -1;
    }
    return n;
}

static void usage(void)
{
    fprintf(stderr, "usage: bench_photons [SCENE] [--photons N] [--reps R] "
                    "[--store photonmap|lightmap|both] [--density D[,D...]] [--k K]\n");
    exit(2);
}

int main(int argc, char **argv)
{
    const char *path = NULL, *store = "both";
    uint64_t photons = 1000000;
    int reps = 3, k_nearest = 32, ndens = 2;
    double dens[8] = {400.0, 2500.0};
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--photons") && i + 1 < argc)
            photons = strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--store") && i + 1 < argc)
            store = argv[++i];
        else if (!strcmp(argv[i], "--k") && i + 1 < argc)
            k_nearest = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--density") && i + 1 < argc) {
            ndens = parse_densities(argv[++i], dens, 8);
            if (ndens < 1)
                usage();
        } else if (argv[i][0] != '-' && !path)
            path = argv[i];
        else
            usage();
    }
    if (!path)
        path = PRISMFARM_SOURCE_DIR "/scenes/prism_beam.pbrt";
    if (photons < 1000 || reps < 1 || reps > 50 || k_nearest < 1 || k_nearest > PHOTON_MAP_MAX_K ||
        (strcmp(store, "photonmap") && strcmp(store, "lightmap") && strcmp(store, "both"))) {
        fprintf(stderr, "bench_photons: --photons must be >= 1000, --reps in 1..50, --k in "
                        "1..1024, --store photonmap, lightmap or both\n");
        return 2;
    }
    int want_pm = strcmp(store, "lightmap") != 0, want_lm = strcmp(store, "photonmap") != 0;

    /* Stores traced (photon maps differ only at gather time, so one traces for both) and
     * stores gathered from. */
    store_cfg_t trace_cfg[10], gather_cfg[10];
    int ntrace = 0, ngather = 0;
    if (want_pm) {
        trace_cfg[ntrace] = (store_cfg_t){.kind = PHOTON_STORE_PHOTONMAP};
        snprintf(trace_cfg[ntrace++].label, 64, "photon map");
        gather_cfg[ngather] = (store_cfg_t){.kind = PHOTON_STORE_PHOTONMAP};
        snprintf(gather_cfg[ngather++].label, 64, "photon map, every photon within r");
        gather_cfg[ngather] = (store_cfg_t){.kind = PHOTON_STORE_PHOTONMAP, .k = k_nearest};
        snprintf(gather_cfg[ngather++].label, 64, "photon map, %d nearest within r", k_nearest);
    }
    for (int d = 0; want_lm && d < ndens; d++) {
        store_cfg_t c = {.kind = PHOTON_STORE_LIGHTMAP, .density = dens[d]};
        snprintf(c.label, 64, "light map, %g texels/unit^2", dens[d]);
        trace_cfg[ntrace++] = c;
        gather_cfg[ngather++] = c;
    }

    int cores = pool_cores();
    char load0[64], load1[64];
    loadavg(load0, sizeof load0);
    scene_t *s = load(path, NULL, CAM_RES, 8);
    if (!s->settings.photon.enabled) {
        fprintf(stderr, "bench_photons: %s has no photon integrator\n", path);
        return 1;
    }
    printf("Scene %s, photon maxdepth %d, %d buckets, gather radius %g, %d cores; median of %d "
           "runs. Load average (1 / 5 / 15 min) at the start: %s.\n\n",
           path, s->settings.photon.maxdepth, s->settings.grid.n, photon_gather_radius(s), cores,
           reps, load0);

    /* 1. One thread. */
    printf("Photon pass on one thread (CPU time), %llu monochrome photons emitted per run:\n\n",
           (unsigned long long)photons);
    printf("| store | monochrome rays per photon | photons traced | CPU s | photons/s per core | "
           "monochrome photons/s per core | rays per photon | held per M emitted | store MB per M "
           "emitted | wire MB per M emitted |\n");
    printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    const int lanes_list[] = {1, 16};
    for (int c = 0; c < ntrace; c++) {
        configure(s, &trace_cfg[c]);
        for (int li = 0; li < 2; li++) {
            int lanes = lanes_list[li];
            uint64_t n = photons / (uint64_t)lanes;
            double t[50];
            size_t mem = 0, wire = 0, held = 0;
            photon_stats_t st;
            for (int r = 0; r < reps; r++)
                t[r] = trace_once(s, n, lanes, &mem, &wire, &held, &st);
            double tm = median(t, reps);
            double per_m = 1e6 / (double)st.emitted;
            printf("| %s | %d | %llu | %.3f | %.3g | %.3g | %.2f | %.0f %s | %.2f | %.3f |\n",
                   trace_cfg[c].label, lanes, (unsigned long long)n, tm, (double)n / tm,
                   (double)st.emitted / tm, (double)st.rays / (double)n, (double)held * per_m,
                   trace_cfg[c].kind == PHOTON_STORE_LIGHTMAP ? "texels" : "photons",
                   (double)mem * per_m / 1e6, (double)wire * per_m / 1e6);
        }
    }
    printf("\nA photon traced with 16 rays splits at the glass into 16 monochrome photons, each "
           "counted as emitted. A photon map grows by the photons it holds (24 bytes each on the "
           "wire, not compressed); a light map by the texels that get power (a 4x4 tile and a "
           "16-texel chunk per bucket at the first deposit there), so its size per photon falls "
           "as more photons land on texels already lit.\n");

    /* 2. Every core: the local pass (threads over contiguous ranges). */
    printf("\nThe local pass on all %d cores (photon_pass_run, %llu photons x %d, store "
           "built):\n\n",
           cores, (unsigned long long)photons, cores);
    printf("| store | wall s | CPU s (all threads) | photons/s | photons per CPU s |\n");
    printf("| --- | --- | --- | --- | --- |\n");
    for (int c = 0; c < ntrace; c++) {
        double t[50], cp[50];
        err_t err;
        configure(s, &trace_cfg[c]);
        s->settings.photon.photons = photons * (uint64_t)cores;
        for (int r = 0; r < reps; r++) {
            double c0 = proc_cpu_s(), t0 = clock_now_s();
            photon_store_t *st = photon_pass_run(s, 0, NULL, NULL, &err);
            if (!st)
                die(err.msg);
            t[r] = clock_now_s() - t0;
            cp[r] = proc_cpu_s() - c0;
            photon_store_destroy(&st);
        }
        double tm = median(t, reps), cm = median(cp, reps);
        double n = (double)s->settings.photon.photons;
        printf("| %s | %.3f | %.3f | %.3g | %.3g |\n", trace_cfg[c].label, tm, cm, n / tm, n / cm);
    }

    /* 3. The gather: each store from the scene's own photon count (1 M for prism_beam) on
     * every core, traced before any timing; then irradiance queries at the camera's diffuse
     * points on one thread, and the camera pass on every core against plain path. */
    gather_pt_t *pts = NULL;
    size_t npts = gather_points(s, &pts);
    scene_t *p = load(path, "path", CAM_RES, 8);
    double tp[50], cpp[50];
    render_stats_t pst_r;
    for (int r = 0; r < reps; r++)
        render_once(p, NULL, &pst_r, &tp[r], &cpp[r]);
    double mp = median(tp, reps), cmp = median(cpp, reps);
    uint64_t gphotons = 0;
    printf("\nThe gather (camera pass at %dx%d, 8 spp, path gather; stores traced "
           "beforehand). Queries: photon_store_irradiance at the first diffuse point of each "
           "pixel's centre ray (%zu points), one thread, CPU time. Camera pass: CPU time of all "
           "threads, against plain path's %.2f CPU s (%.2f s wall, %.2f M rays per CPU s).\n\n",
           p->settings.xres, p->settings.yres, npts, cmp, mp, pst_r.rays / cmp / 1e6);
    printf("| store | store MB | wire MB | points with power | ns per query | camera pass CPU s "
           "| wall s | gather's cost vs path |\n");
    printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (int c = 0; c < ngather; c++) {
        err_t err;
        scene_t *g = load(path, NULL, CAM_RES, 8);
        configure(g, &gather_cfg[c]);
        gphotons = g->settings.photon.photons;
        photon_store_t *st = photon_pass_run(g, 0, NULL, NULL, &err);
        if (!st)
            die(err.msg);
        double found = 0, ns = gather_ns(st, pts, npts, &found);
        double tq[50], cq[50];
        render_stats_t a;
        for (int r = 0; r < reps; r++)
            render_once(g, st, &a, &tq[r], &cq[r]);
        double mq = median(tq, reps), cm = median(cq, reps);
        /* The photon map's wire form needs an unfinished map: 24 bytes a photon and a 32-byte
         * header (photon_map.h). */
        size_t wire = photon_store_lightmap(st) ? wire_bytes(st) : 32 + 24 * photon_store_count(st);
        printf("| %s | %.2f | %.3f | %.1f %% | %.0f | %.3f | %.3f | %+.1f %% |\n",
               gather_cfg[c].label, photon_store_memory_bytes(st) / 1e6, wire / 1e6, 100.0 * found,
               ns, cm, mq, 100.0 * (cm / cmp - 1.0));
        photon_store_destroy(&st);
        scene_destroy(&g);
    }
    printf("\nStores of %llu photons (the scene's count); \"gather's cost\" is the camera pass's "
           "CPU time over plain path's minus 1: it includes the gather queries and the paths "
           "that end at a caustic instead of tracing on.\n",
           (unsigned long long)gphotons);
    loadavg(load1, sizeof load1);
    printf("\nLoad average at the end: %s.\n", load1);
    free(pts);
    scene_destroy(&p);
    scene_destroy(&s);
    return 0;
}
