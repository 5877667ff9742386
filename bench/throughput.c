/* bench_throughput: how close the path tracer comes to Embree's own speed (docs/throughput.md).
 * For every scene, at a small size:
 *   1. rays per second of the renderer (render_stats rays over local_render's time) with one
 *      thread and with every core;
 *   2. the same rays on Embree alone: the renderer's queries are recorded once through
 *      geometry_set_query_hook (float ray, tmin/tmax, intersect or occluded), then replayed in
 *      the recorded order with plain rtcIntersect1/rtcOccluded1 on the scene's own RTCScene,
 *      from the same number of threads; the ratio of the two is the share of the renderer's
 *      time that goes into Embree's traversal (target: at least 0.6);
 *   3. the same rays through Embree's stream (rtcIntersect1M) and packet (rtcIntersect4/8/16)
 *      queries, grouped in recorded order by query kind: an upper bound on raw throughput;
 *   4. local_render's wall time with 1..N threads and its speed-up over one thread;
 *   5. photons per CPU second of one thread (photon_trace) on the scenes with a photon pass.
 * usage: bench_throughput [--res WxH] [--spp N] [--reps R] [--threads N] [--photons N]
 *                         [--profile] [SCENE...]
 *   defaults: 160x120, 16 spp, 3 repetitions, N = every core, 100000 photons, every .pbrt
 *   file of scenes/. --profile renders each scene with one thread R times and nothing else (for
 *   perf record). Prints Markdown; a figure is the median of the repetitions, the modes of one
 *   repetition run one after the other so that they share the machine's state. Single-thread
 *   figures use CPU time, which moves much less than wall-clock time on a shared machine. */
#include "local_render.h"
#include "pool.h"
#include "photon_pass.h"
#include "render.h"
#include "scene_load.h"

#include <embree3/rtcore.h>
#include <glob.h>
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#define REPS_MAX 50
#define THREADS_MAX 64

static double clock_s(clockid_t id)
{
    struct timespec t;
    clock_gettime(id, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}
static double wall_s(void) { return clock_s(CLOCK_MONOTONIC); }
static double thread_cpu_s(void) { return clock_s(CLOCK_THREAD_CPUTIME_ID); }
static double process_cpu_s(void) { return clock_s(CLOCK_PROCESS_CPUTIME_ID); }

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median of v[0..n) (v is reordered). */
static double median(double *v, int n)
{
    if (n <= 0)
        return 0.0;
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static double safe_div(double a, double b) { return b > 0.0 ? a / b : 0.0; }

static void die(const char *what, const char *msg)
{
    fprintf(stderr, "bench_throughput: %s: %s\n", what, msg);
    exit(1);
}

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p)
        die("malloc", "out of memory");
    return p;
}

/* aligned_alloc wants a size that is a multiple of the alignment. */
static void *xaligned(size_t align, size_t n)
{
    size_t size = (n + align - 1) / align * align;
    void *p = aligned_alloc(align, size ? size : align);
    if (!p)
        die("aligned_alloc", "out of memory");
    return p;
}

/* ------------------------------------------------------------------ the machine */

/* Busy CPU seconds of the whole machine (user, nice, system, irq, softirq, steal of
 * /proc/stat's "cpu" line), to tell how much of it other processes took during the run. */
static double machine_busy_s(void)
{
    FILE *f = fopen("/proc/stat", "r");
    if (!f)
        return 0.0;
    unsigned long long v[8] = {0};
    int n = fscanf(f, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3],
                   &v[4], &v[5], &v[6], &v[7]);
    fclose(f);
    long hz = sysconf(_SC_CLK_TCK);
    if (n != 8 || hz <= 0)
        return 0.0;
    return (double)(v[0] + v[1] + v[2] + v[5] + v[6] + v[7]) / (double)hz;
}

static double own_cpu_s(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru))
        return 0.0;
    return (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
           (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec;
}

static void load_average(char *out, size_t n)
{
    snprintf(out, n, "?");
    FILE *f = fopen("/proc/loadavg", "r");
    if (!f)
        return;
    double a, b, c;
    if (fscanf(f, "%lf %lf %lf", &a, &b, &c) == 3)
        snprintf(out, n, "%.2f %.2f %.2f", a, b, c);
    fclose(f);
}

static void cpu_model(char *out, size_t n)
{
    snprintf(out, n, "unknown CPU");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        char *colon = strchr(line, ':');
        if (!strncmp(line, "model name", 10) && colon) {
            snprintf(out, n, "%s", colon + 2);
            out[strcspn(out, "\n")] = 0;
            break;
        }
    }
    fclose(f);
}

/* ------------------------------------------------------------------ recording the rays */

typedef struct ray_log {
    geometry_query_t *q;
    size_t n, cap;
    int failed;
} ray_log_t;

/* The query hook: appends every query. Recording runs on one render thread, so no lock. */
static void log_query(void *user, const geometry_query_t *q)
{
    ray_log_t *log = user;
    if (log->n == log->cap) {
        size_t cap = log->cap ? 2 * log->cap : 1u << 16;
        geometry_query_t *nq = realloc(log->q, cap * sizeof *nq);
        if (!nq) {
            log->failed = 1;
            return;
        }
        log->q = nq;
        log->cap = cap;
    }
    log->q[log->n++] = *q;
}

/* The RTCRayHit geometry_intersect passes to Embree for query q; ray.id (the application's
 * own field, which Embree does not read) carries the query's kind. */
static struct RTCRayHit rayhit_of(const geometry_query_t *q)
{
    struct RTCRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray = (struct RTCRay){.org_x = q->org[0], .org_y = q->org[1], .org_z = q->org[2],
                             .tnear = q->tnear, .dir_x = q->dir[0], .dir_y = q->dir[1],
                             .dir_z = q->dir[2], .tfar = q->tfar, .mask = 0xFFFFFFFFu,
                             .id = (unsigned)q->occluded, .flags = 0};
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

/* ------------------------------------------------------------------ the renderer */

typedef struct run {
    double wall, cpu;
    uint64_t rays;
} run_t;

static run_t render_run(const scene_t *s, const photon_store_t *photons, int threads)
{
    err_t err;
    const render_settings_t *rs = &s->settings;
    tilebuf_t *img = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    if (!img)
        die("tilebuf_new", err.msg);
    local_render_opts_t o = {.threads = threads, .photons = photons};
    render_stats_t st = {0};
    double w0 = wall_s(), c0 = process_cpu_s();
    if (local_render(s, &o, img, &st, NULL, &err))
        die("local_render", err.msg);
    run_t r = {.wall = wall_s() - w0, .cpu = process_cpu_s() - c0, .rays = st.rays};
    tilebuf_destroy(&img);
    return r;
}

/* ------------------------------------------------------------------ replay: one ray at a time */

typedef struct replay_part {
    RTCScene scene;
    struct RTCRayHit *rh; /* this thread's rays, built before the clock starts */
    const geometry_query_t *q;
    size_t n;
    pthread_barrier_t *start;
    double w0, w1, cpu;
} replay_part_t;

static void *replay_thread(void *arg)
{
    replay_part_t *p = arg;
    pool_fp_mode_set(); /* the compute threads' mode (base/pool.h) */
    for (size_t i = 0; i < p->n; i++)
        p->rh[i] = rayhit_of(&p->q[i]);
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    pthread_barrier_wait(p->start);
    /* Only the Embree calls are in the loop: the rays are ready in memory, as geometry.c has
     * them on its stack. */
    p->w0 = wall_s();
    double c0 = thread_cpu_s();
    for (size_t i = 0; i < p->n; i++) {
        if (p->rh[i].ray.id)
            rtcOccluded1(p->scene, &ctx, &p->rh[i].ray);
        else
            rtcIntersect1(p->scene, &ctx, &p->rh[i]);
    }
    p->cpu = thread_cpu_s() - c0;
    p->w1 = wall_s();
    return NULL;
}

/* Replays the log on nthreads threads, each a contiguous share in recorded order (as
 * local_render's threads take whole tiles). rh (log->n entries) receives the results. */
static run_t replay_run(RTCScene scene, const ray_log_t *log, int nthreads, struct RTCRayHit *rh)
{
    replay_part_t parts[THREADS_MAX];
    pthread_t th[THREADS_MAX];
    pthread_barrier_t start;
    if (pthread_barrier_init(&start, NULL, (unsigned)nthreads))
        die("pthread_barrier_init", "failed");
    for (int i = 0; i < nthreads; i++) {
        size_t b = log->n * (size_t)i / (size_t)nthreads, e = log->n * (size_t)(i + 1) / (size_t)nthreads;
        parts[i] = (replay_part_t){.scene = scene, .rh = rh + b, .q = log->q + b, .n = e - b,
                                   .start = &start};
        if (pthread_create(&th[i], NULL, replay_thread, &parts[i]))
            die("pthread_create", "failed");
    }
    run_t r = {.rays = log->n};
    double w0 = INFINITY, w1 = -INFINITY;
    for (int i = 0; i < nthreads; i++) {
        pthread_join(th[i], NULL);
        w0 = fmin(w0, parts[i].w0);
        w1 = fmax(w1, parts[i].w1);
        r.cpu += parts[i].cpu;
    }
    pthread_barrier_destroy(&start);
    r.wall = w1 - w0;
    return r;
}

/* ------------------------------------------------------------------ replay: streams and packets */

/* Embree's SoA packets: RTCRayHitW is the 12 ray fields then the 8 hit fields, each an array
 * of W 4-byte values (rtcore_ray.h). */
enum { RAY_ORG_X, RAY_ORG_Y, RAY_ORG_Z, RAY_TNEAR, RAY_DIR_X, RAY_DIR_Y, RAY_DIR_Z, RAY_TIME,
       RAY_TFAR, RAY_MASK, RAY_ID, RAY_FLAGS, HIT_NG_X, HIT_NG_Y, HIT_NG_Z, HIT_U, HIT_V,
       HIT_PRIM, HIT_GEOM, HIT_INST, SOA_FIELDS };
_Static_assert(sizeof(struct RTCRayHit8) == SOA_FIELDS * 8 * 4, "RTCRayHit8 layout");
_Static_assert(offsetof(struct RTCRayHit8, hit.geomID) == HIT_GEOM * 8 * 4, "RTCRayHit8 layout");
_Static_assert(offsetof(struct RTCRayHit16, ray.tfar) == RAY_TFAR * 16 * 4, "RTCRayHit16 layout");

typedef enum { MODE_STREAM, MODE_PACKET4, MODE_PACKET8, MODE_PACKET16, NMODES } query_mode_t;
static const char *const mode_name[NMODES] = {"rtcIntersect1M", "rtcIntersect4", "rtcIntersect8",
                                              "rtcIntersect16"};
static const int mode_width[NMODES] = {0, 4, 8, 16};
/* Rays per rtcIntersect1M call. */
#define STREAM_CHUNK 256

typedef struct packet_result {
    int supported;
    double cpu;
    size_t mismatches; /* rays whose hit (or occlusion) differs from rtcIntersect1's */
    int error;         /* Embree reported an error during the calls */
} packet_result_t;

static void soa_set_f(uint32_t *soa, int w, int field, int lane, float v)
{
    memcpy(&soa[field * w + lane], &v, sizeof v);
}

static int same_hit(const struct RTCRayHit *a, unsigned geom, unsigned prim, unsigned inst,
                    float tfar, int occluded)
{
    if (occluded)
        return (a->ray.tfar == -INFINITY) == (tfar == -INFINITY);
    if (a->hit.geomID != geom)
        return 0;
    return geom == RTC_INVALID_GEOMETRY_ID || (a->hit.primID == prim && a->hit.instID[0] == inst);
}

/* One thread: the log's intersections then its occlusion queries, each in recorded order,
 * through mode. ref holds rtcIntersect1's results to check against. */
static packet_result_t packet_run(RTCScene scene, const ray_log_t *log, query_mode_t mode,
                                  const struct RTCRayHit *ref)
{
    packet_result_t res = {0};
    RTCDevice dev = rtcGetSceneDevice(scene); /* counted reference */
    static const enum RTCDeviceProperty prop[NMODES] = {
        RTC_DEVICE_PROPERTY_RAY_STREAM_SUPPORTED, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED,
        RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED};
    res.supported = dev && rtcGetDeviceProperty(dev, prop[mode]) != 0;
    if (!res.supported) {
        if (dev)
            rtcReleaseDevice(dev);
        return res;
    }
    rtcGetDeviceError(dev); /* clears an earlier error code */
    size_t n = log->n;
    size_t *order = xmalloc((n ? n : 1) * sizeof *order);
    size_t nint = 0, k = 0;
    for (size_t i = 0; i < n; i++)
        if (!log->q[i].occluded)
            order[k++] = i;
    nint = k;
    for (size_t i = 0; i < n; i++)
        if (log->q[i].occluded)
            order[k++] = i;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (mode == MODE_STREAM) {
        struct RTCRayHit *rh = xaligned(64, (n ? n : 1) * sizeof *rh);
        for (size_t i = 0; i < n; i++)
            rh[i] = rayhit_of(&log->q[order[i]]);
        double c0 = thread_cpu_s();
        for (size_t i = 0; i < nint; i += STREAM_CHUNK) {
            size_t m = nint - i < STREAM_CHUNK ? nint - i : STREAM_CHUNK;
            rtcIntersect1M(scene, &ctx, rh + i, (unsigned)m, sizeof *rh);
        }
        for (size_t i = nint; i < n; i += STREAM_CHUNK) {
            size_t m = n - i < STREAM_CHUNK ? n - i : STREAM_CHUNK;
            rtcOccluded1M(scene, &ctx, &rh[i].ray, (unsigned)m, sizeof *rh);
        }
        res.cpu = thread_cpu_s() - c0;
        for (size_t i = 0; i < n; i++)
            res.mismatches += !same_hit(&ref[order[i]], rh[i].hit.geomID, rh[i].hit.primID,
                                        rh[i].hit.instID[0], rh[i].ray.tfar, i >= nint);
        free(rh);
    } else {
        const int w = mode_width[mode];
        size_t pk_int = (nint + (size_t)w - 1) / (size_t)w, pk_occ = (n - nint + (size_t)w - 1) / (size_t)w;
        size_t npk = pk_int + pk_occ, words = (size_t)SOA_FIELDS * (size_t)w;
        uint32_t *soa = xaligned(64, (npk ? npk : 1) * words * sizeof *soa);
        /* rtcIntersectW wants the valid mask aligned like the packet (4 W bytes). */
        int *valid = xaligned(64, (npk ? npk : 1) * (size_t)w * sizeof *valid);
        size_t *lane_ray = xmalloc((npk ? npk : 1) * (size_t)w * sizeof *lane_ray);
        memset(soa, 0, npk * words * sizeof *soa);
        for (size_t pk = 0; pk < npk; pk++) {
            uint32_t *p = soa + pk * words;
            size_t first = pk < pk_int ? pk * (size_t)w : nint + (pk - pk_int) * (size_t)w;
            size_t end = pk < pk_int ? nint : n;
            for (int l = 0; l < w; l++) {
                size_t i = first + (size_t)l;
                int on = i < end;
                valid[pk * (size_t)w + (size_t)l] = on ? -1 : 0;
                lane_ray[pk * (size_t)w + (size_t)l] = on ? order[i] : SIZE_MAX;
                const geometry_query_t *q = on ? &log->q[order[i]] : &log->q[0];
                soa_set_f(p, w, RAY_ORG_X, l, q->org[0]);
                soa_set_f(p, w, RAY_ORG_Y, l, q->org[1]);
                soa_set_f(p, w, RAY_ORG_Z, l, q->org[2]);
                soa_set_f(p, w, RAY_TNEAR, l, q->tnear);
                soa_set_f(p, w, RAY_DIR_X, l, q->dir[0]);
                soa_set_f(p, w, RAY_DIR_Y, l, q->dir[1]);
                soa_set_f(p, w, RAY_DIR_Z, l, q->dir[2]);
                soa_set_f(p, w, RAY_TFAR, l, q->tfar);
                p[RAY_MASK * w + l] = 0xFFFFFFFFu;
                p[HIT_GEOM * w + l] = RTC_INVALID_GEOMETRY_ID;
                p[HIT_INST * w + l] = RTC_INVALID_GEOMETRY_ID;
            }
        }
        double c0 = thread_cpu_s();
        for (size_t pk = 0; pk < npk; pk++) {
            void *p = soa + pk * words;
            const int *v = valid + pk * (size_t)w;
            int occ = pk >= pk_int;
            switch (mode) {
            case MODE_PACKET4:
                if (occ)
                    rtcOccluded4(v, scene, &ctx, p);
                else
                    rtcIntersect4(v, scene, &ctx, p);
                break;
            case MODE_PACKET8:
                if (occ)
                    rtcOccluded8(v, scene, &ctx, p);
                else
                    rtcIntersect8(v, scene, &ctx, p);
                break;
            default:
                if (occ)
                    rtcOccluded16(v, scene, &ctx, p);
                else
                    rtcIntersect16(v, scene, &ctx, p);
                break;
            }
        }
        res.cpu = thread_cpu_s() - c0;
        for (size_t pk = 0; pk < npk; pk++) {
            const uint32_t *p = soa + pk * words;
            for (int l = 0; l < w; l++) {
                size_t i = lane_ray[pk * (size_t)w + (size_t)l];
                if (i == SIZE_MAX)
                    continue;
                float tfar;
                memcpy(&tfar, &p[RAY_TFAR * w + l], sizeof tfar);
                res.mismatches += !same_hit(&ref[i], p[HIT_GEOM * w + l], p[HIT_PRIM * w + l],
                                            p[HIT_INST * w + l], tfar, pk >= pk_int);
            }
        }
        free(soa);
        free(valid);
        free(lane_ray);
    }
    res.error = rtcGetDeviceError(dev) != RTC_ERROR_NONE;
    rtcReleaseDevice(dev);
    free(order);
    return res;
}

/* ------------------------------------------------------------------ photons */

typedef struct photon_figures {
    uint64_t photons, rays;
    double cpu;
} photon_figures_t;

static photon_figures_t photon_run(const scene_t *s, uint64_t n)
{
    err_t err;
    photon_job_t job = photon_job_from_settings(&s->settings);
    photon_store_t *store = photon_store_new(s, &err);
    if (!store)
        die("photon_store_new", err.msg);
    photon_stats_t st = {0};
    double c0 = thread_cpu_s();
    if (photon_trace(s, &job, 0, n, store, &st, &err))
        die("photon_trace", err.msg);
    photon_figures_t f = {.photons = st.emitted, .rays = st.rays, .cpu = thread_cpu_s() - c0};
    photon_store_destroy(&store);
    return f;
}

/* ------------------------------------------------------------------ per scene */

typedef struct scene_figures {
    char name[64];
    int photon;        /* the scene has a photon pass */
    uint64_t rays;     /* per render */
    uint64_t samples;  /* per render */
    double render_wall[THREADS_MAX + 1], render_cpu[THREADS_MAX + 1]; /* medians; index = threads */
    double replay_wall[THREADS_MAX + 1], replay_cpu1;
    packet_result_t packet[NMODES];
    double packet_cpu[NMODES];
    photon_figures_t ph; /* cpu: median */
    int ph_done;
} scene_figures_t;

typedef struct options {
    int xres, yres, spp, reps, threads, profile;
    uint64_t photons;
} options_t;

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

static scene_t *load(const char *path, const options_t *o, photon_store_t **photons)
{
    err_t err;
    scene_overrides_t ov = {.seed = -1, .xres = o->xres, .yres = o->yres, .spp = o->spp};
    scene_t *s = scene_load_file(path, &ov, &err);
    if (!s)
        die(path, err.msg);
    if (s->settings.photon.enabled) {
        /* The camera pass's store, traced now on every core so that no render below pays
         * for it (and its rays are not recorded). */
        if (!(*photons = photon_pass_run(s, 0, NULL, NULL, &err)))
            die(path, err.msg);
    }
    return s;
}

static void bench_scene(const char *path, const options_t *o, scene_figures_t *f)
{
    memset(f, 0, sizeof *f);
    snprintf(f->name, sizeof f->name, "%s", base_name(path));
    photon_store_t *photons = NULL;
    scene_t *s = load(path, o, &photons);
    f->photon = s->settings.photon.enabled;
    RTCScene rtc = geometry_embree_scene(s->geometry);
    if (!rtc)
        die(path, "the scene's geometry is not committed");

    /* Record the rays of one single-thread render: the same rays whatever the thread count,
     * since every random number depends on (seed, pixel, sample, dimension) only. */
    ray_log_t log = {0};
    geometry_set_query_hook(s->geometry, log_query, &log);
    run_t rec = render_run(s, photons, 1);
    geometry_set_query_hook(s->geometry, NULL, NULL);
    if (log.failed)
        die(path, "out of memory recording the rays");
    if (log.n != rec.rays)
        fprintf(stderr, "bench_throughput: %s: %zu queries recorded, render_stats counted %llu rays\n",
                path, log.n, (unsigned long long)rec.rays);
    f->rays = rec.rays;
    f->samples = (uint64_t)s->settings.xres * (uint64_t)s->settings.yres * (uint64_t)s->settings.spp;
    struct RTCRayHit *ref = xaligned(64, (log.n ? log.n : 1) * sizeof *ref);

    double rw[THREADS_MAX + 1][REPS_MAX], pw[THREADS_MAX + 1][REPS_MAX];
    double rc[THREADS_MAX + 1][REPS_MAX], pc1[REPS_MAX], kc[NMODES][REPS_MAX];
    for (int r = 0; r < o->reps; r++) {
        for (int t = 1; t <= o->threads; t++) {
            run_t a = render_run(s, photons, t);
            run_t b = replay_run(rtc, &log, t, ref);
            rw[t][r] = a.wall;
            rc[t][r] = a.cpu;
            pw[t][r] = b.wall;
            if (t == 1)
                pc1[r] = b.cpu;
        }
        for (int m = 0; m < NMODES; m++) {
            f->packet[m] = packet_run(rtc, &log, (query_mode_t)m, ref);
            kc[m][r] = f->packet[m].cpu;
        }
    }
    for (int t = 1; t <= o->threads; t++) {
        f->render_wall[t] = median(rw[t], o->reps);
        f->render_cpu[t] = median(rc[t], o->reps);
        f->replay_wall[t] = median(pw[t], o->reps);
    }
    f->replay_cpu1 = median(pc1, o->reps);
    for (int m = 0; m < NMODES; m++)
        f->packet_cpu[m] = median(kc[m], o->reps);

    if (f->photon && o->photons > 0) {
        double pc[REPS_MAX];
        for (int r = 0; r < o->reps; r++) {
            f->ph = photon_run(s, o->photons);
            pc[r] = f->ph.cpu;
        }
        f->ph.cpu = median(pc, o->reps);
        f->ph_done = 1;
    }
    free(ref);
    free(log.q);
    photon_store_destroy(&photons);
    scene_destroy(&s);
}

/* --profile: the renderer alone, one thread, for perf record. The renders' CLOCK_MONOTONIC
 * window goes to stderr, for `perf record -k CLOCK_MONOTONIC` then `perf report --time` to
 * leave out the scene's loading and photon pass. */
static void profile_scene(const char *path, const options_t *o)
{
    photon_store_t *photons = NULL;
    scene_t *s = load(path, o, &photons);
    double w0 = wall_s();
    for (int r = 0; r < o->reps; r++) {
        run_t a = render_run(s, photons, 1);
        printf("%s: %llu rays in %.3f CPU s, %.2f M rays per CPU second\n", base_name(path),
               (unsigned long long)a.rays, a.cpu, safe_div((double)a.rays, a.cpu) / 1e6);
    }
    fprintf(stderr, "profile window %s: %.6f,%.6f\n", base_name(path), w0, wall_s());
    photon_store_destroy(&photons);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------ report */

static double mrays(uint64_t rays, double s) { return safe_div((double)rays, s) / 1e6; }

static void report(const scene_figures_t *f, int nf, const options_t *o)
{
    const int n = o->threads;
    printf("**Renderer against Embree on the same rays** (one thread, CPU time; target: ratio "
           "≥ 0.6)\n\n");
    printf("| scene | rays per sample | renderer M rays/s | rtcIntersect1/rtcOccluded1 M rays/s "
           "| ratio | best stream/packet M rays/s | ratio to it | target ≥ 0.6 |\n");
    printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (int i = 0; i < nf; i++) {
        const scene_figures_t *s = &f[i];
        double rr = mrays(s->rays, s->render_cpu[1]), raw = mrays(s->rays, s->replay_cpu1);
        int best = -1;
        for (int m = 0; m < NMODES; m++)
            if (s->packet[m].supported && !s->packet[m].error && s->packet[m].mismatches == 0 &&
                (best < 0 || s->packet_cpu[m] < s->packet_cpu[best]))
                best = m;
        double bp = best >= 0 ? mrays(s->rays, s->packet_cpu[best]) : 0.0;
        printf("| `%s` | %.2f | %.2f | %.2f | %.3f | ", s->name,
               safe_div((double)s->rays, (double)s->samples), rr, raw, safe_div(rr, raw));
        if (best >= 0)
            printf("%.2f (%s) | %.3f", bp, mode_name[best], safe_div(rr, bp));
        else
            printf("none agrees with rtcIntersect1 | –");
        printf(" | %s |\n", safe_div(rr, raw) >= 0.6 ? "**met**" : "**missed**");
    }

    printf("\n**With every core** (%d threads, wall-clock time; replay: each thread a contiguous "
           "share of the rays)\n\n", n);
    printf("| scene | renderer M rays/s | Embree M rays/s | ratio |\n| --- | --- | --- | --- |\n");
    for (int i = 0; i < nf; i++) {
        const scene_figures_t *s = &f[i];
        double rr = mrays(s->rays, s->render_wall[n]), raw = mrays(s->rays, s->replay_wall[n]);
        printf("| `%s` | %.2f | %.2f | %.3f |\n", s->name, rr, raw, safe_div(rr, raw));
    }

    printf("\n**Embree's query kinds on the same rays** (one thread, M rays per CPU second; "
           "streams and packets take the intersections then the occlusion queries, each in "
           "recorded order; \"differ\" counts rays whose hit differs from rtcIntersect1's)\n\n");
    printf("| scene | rtcIntersect1 |");
    for (int m = 0; m < NMODES; m++)
        printf(" %s |", mode_name[m]);
    printf("\n| --- | --- |");
    for (int m = 0; m < NMODES; m++)
        printf(" --- |");
    printf("\n");
    for (int i = 0; i < nf; i++) {
        const scene_figures_t *s = &f[i];
        printf("| `%s` | %.2f |", s->name, mrays(s->rays, s->replay_cpu1));
        for (int m = 0; m < NMODES; m++) {
            const packet_result_t *p = &s->packet[m];
            if (!p->supported)
                printf(" not supported |");
            else if (p->error)
                printf(" Embree error |");
            else if (p->mismatches)
                printf(" %.2f (%zu differ) |", mrays(s->rays, s->packet_cpu[m]), p->mismatches);
            else
                printf(" %.2f |", mrays(s->rays, s->packet_cpu[m]));
        }
        printf("\n");
    }

    printf("\n**Scaling of local_render** (wall-clock seconds; speed-up over one thread; and the "
           "CPU seconds all threads used over one thread's, which other processes on the "
           "machine move much less: 1.00 means threads cost nothing extra)\n\n");
    printf("| scene |");
    for (int t = 1; t <= n; t++)
        printf(" %d thread%s |", t, t > 1 ? "s" : "");
    for (int t = 2; t <= n; t++)
        printf(" speed-up %d |", t);
    for (int t = 2; t <= n; t++)
        printf(" CPU s %d / 1 |", t);
    printf("\n| --- |");
    for (int t = 1; t <= 3 * n - 2; t++)
        printf(" --- |");
    printf("\n");
    for (int i = 0; i < nf; i++) {
        const scene_figures_t *s = &f[i];
        printf("| `%s` |", s->name);
        for (int t = 1; t <= n; t++)
            printf(" %.3f |", s->render_wall[t]);
        for (int t = 2; t <= n; t++)
            printf(" %.2f |", safe_div(s->render_wall[1], s->render_wall[t]));
        for (int t = 2; t <= n; t++)
            printf(" %.2f |", safe_div(s->render_cpu[t], s->render_cpu[1]));
        printf("\n");
    }

    int any = 0;
    for (int i = 0; i < nf; i++)
        any |= f[i].ph_done;
    if (any) {
        printf("\n**Photons per CPU second of one thread** (photon_trace of photons [0, %llu), "
               "the scene's own photon settings)\n\n", (unsigned long long)o->photons);
        printf("| scene | photons | CPU s | photons/s per core | rays per photon | M rays/s |\n");
        printf("| --- | --- | --- | --- | --- | --- |\n");
        for (int i = 0; i < nf; i++) {
            const scene_figures_t *s = &f[i];
            if (!s->ph_done)
                continue;
            printf("| `%s` | %llu | %.3f | %.3g | %.2f | %.2f |\n", s->name,
                   (unsigned long long)s->ph.photons, s->ph.cpu,
                   safe_div((double)s->ph.photons, s->ph.cpu),
                   safe_div((double)s->ph.rays, (double)s->ph.photons), mrays(s->ph.rays, s->ph.cpu));
        }
    }
}

static int parse_res(const char *s, int *x, int *y)
{
    char *end;
    long a = strtol(s, &end, 10);
    if (*end != 'x')
        return -1;
    long b = strtol(end + 1, &end, 10);
    if (*end || a < 1 || b < 1 || a > 8192 || b > 8192)
        return -1;
    *x = (int)a;
    *y = (int)b;
    return 0;
}

static void usage(void)
{
    fprintf(stderr, "usage: bench_throughput [--res WxH] [--spp N] [--reps R] [--threads N] "
                    "[--photons N] [--profile] [SCENE...]\n");
    exit(2);
}

int main(int argc, char **argv)
{
    options_t o = {.xres = 160, .yres = 120, .spp = 16, .reps = 3,
                   .threads = pool_cores(), .photons = 100000};
    const char **paths = xmalloc((size_t)argc * sizeof *paths);
    int npaths = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--res") && v) {
            if (parse_res(v, &o.xres, &o.yres))
                usage();
            i++;
        } else if (!strcmp(a, "--spp") && v) {
            o.spp = atoi(v);
            i++;
        } else if (!strcmp(a, "--reps") && v) {
            o.reps = atoi(v);
            i++;
        } else if (!strcmp(a, "--threads") && v) {
            o.threads = atoi(v);
            i++;
        } else if (!strcmp(a, "--photons") && v) {
            o.photons = strtoull(v, NULL, 10);
            i++;
        } else if (!strcmp(a, "--profile")) {
            o.profile = 1;
        } else if (a[0] != '-') {
            paths[npaths++] = a;
        } else {
            usage();
        }
    }
    if (o.spp < 1 || o.reps < 1 || o.reps > REPS_MAX || o.threads < 1 || o.threads > THREADS_MAX) {
        fprintf(stderr, "bench_throughput: --spp >= 1, --reps in 1..%d, --threads in 1..%d\n",
                REPS_MAX, THREADS_MAX);
        return 2;
    }
    glob_t g = {0};
    if (npaths == 0) {
        if (glob(PRISMFARM_SOURCE_DIR "/scenes/*.pbrt", 0, NULL, &g) || g.gl_pathc == 0)
            die("glob", "no scenes/*.pbrt");
        free(paths);
        paths = xmalloc(g.gl_pathc * sizeof *paths);
        for (size_t i = 0; i < g.gl_pathc; i++)
            paths[npaths++] = g.gl_pathv[i];
    }
    pool_fp_mode_set(); /* the photon figures trace on this thread */
    if (o.profile) {
        for (int i = 0; i < npaths; i++)
            profile_scene(paths[i], &o);
        globfree(&g);
        free(paths);
        return 0;
    }

    char cpu[256], load0[64], load1[64];
    cpu_model(cpu, sizeof cpu);
    load_average(load0, sizeof load0);
    double busy0 = machine_busy_s(), own0 = own_cpu_s(), t0 = wall_s();
    scene_figures_t *f = xmalloc((size_t)npaths * sizeof *f);
    for (int i = 0; i < npaths; i++) {
        fprintf(stderr, "bench_throughput: %s\n", paths[i]);
        bench_scene(paths[i], &o, &f[i]);
    }
    double elapsed = wall_s() - t0;
    double others = safe_div(machine_busy_s() - busy0 - (own_cpu_s() - own0), elapsed);
    load_average(load1, sizeof load1);

    printf("Machine: %s, %d cores; Embree %d.%d.%d. Load average (1, 5, 15 min) %s before, %s "
           "after; other processes used %.2f of the %d cores on average during the %.0f s run.\n",
           cpu, pool_cores(), RTC_VERSION_MAJOR, RTC_VERSION_MINOR, RTC_VERSION_PATCH,
           load0, load1, others < 0 ? 0.0 : others, pool_cores(), elapsed);
    printf("Every scene at %dx%d, %d spp; median of %d repetitions.\n\n", o.xres, o.yres, o.spp,
           o.reps);
    report(f, npaths, &o);
    free(f);
    globfree(&g);
    free(paths);
    return 0;
}
