/* prismfarm render: renders a scene on this machine's cores and writes the spectral EXR and a
 * PNG preview. */
#include "commands.h"

#include "cli_args.h"
#include "error_estimate.h"
#include "film.h"
#include "local_farm.h"
#include "local_render.h"
#include "photon.h"
#include "progress.h"
#include "scene_load.h"
#include "passes.h"

#include <errno.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

static void usage(FILE *out)
{
    fprintf(out,
            "usage: prismfarm render SCENE.pbrt [options]\n"
            "\n"
            "Renders SCENE on this machine through the farm's code path (a master and workers in\n"
            "this process over inproc://); writes a spectral OpenEXR (Fichet et al. layout, float32,\n"
            "with linear sRGB R,G,B channels) and a tone-mapped PNG preview beside it.\n"
            "Options override the scene file:\n"
            "  -o, --output OUT.exr     output file (default: the Film's filename, else SCENE.exr)\n"
            CLI_OVERRIDES_HELP
            CLI_STOP_HELP
            "  --threads N              render threads per worker (default: all cores / workers)\n"
            "  --workers N              workers in this process (default 1)\n"
            "  --tile N                 tile size in pixels (default 32)\n"
            "  --direct                 render with plain threads, without the farm's master and\n"
            "                           workers (same pixels up to rounding; for comparisons; with\n"
            "                           a stopping rule, in the farm's passes: the same pixels)\n"

            "  --exposure STOPS         preview exposure (default 0)\n"
            "  --quiet                  no progress output\n");
}

static void on_progress(void *user, uint64_t done, uint64_t total, double elapsed)
{
    progress_update(user, done, total, elapsed);
}

static int make_parent_dirs(const char *path)
{
    char buf[PATH_MAX];
    snprintf(buf, sizeof buf, "%s", path);
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = 0;
        if (mkdir(buf, 0777) && errno != EEXIST)
            return -1;
        *p = '/';
    }
    return 0;
}

static double seconds_since(const struct timespec *t0)
{
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    return (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
}

/* One progressive pass of --direct with a stopping rule, shared by its threads. */
typedef struct pass_run {
    const scene_t *scene;
    int tile, tiles_x, ntiles, next;
    uint32_t sb, se;
    tilebuf_t *pass;         /* this pass's samples over the whole image */
    double deadline;         /* seconds since t0 after which the pass is dropped; 0: never */
    const struct timespec *t0;
    int failed, abandoned;
    err_t err;
    render_stats_t stats;
    uint64_t samples_before; /* of the passes merged, for the progress line */
    uint64_t samples_done, samples_total;
    progress_t *prog;
    pthread_mutex_t lock;
} pass_run_t;

static void *pass_thread(void *arg)
{
    pass_run_t *r = arg;
    const render_settings_t *rs = &r->scene->settings;
#if defined(__SSE__)
    /* As every render thread (local_render.c, worker_daemon.c): Embree's advice, and the same
     * floating-point mode as the farm's workers, so the bytes match theirs. */
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    for (;;) {
        pthread_mutex_lock(&r->lock);
        /* Past the time limit, a pass with tiles left is dropped: a tile already rendering
         * finishes, no other starts (the farm's workers are told to cancel, as for a cancel). */
        if (!r->failed && !r->abandoned && r->next < r->ntiles && r->deadline > 0 &&
            seconds_since(r->t0) >= r->deadline)
            r->abandoned = 1;
        int t = r->failed || r->abandoned ? r->ntiles : r->next++;
        pthread_mutex_unlock(&r->lock);
        if (t >= r->ntiles)
            return NULL;
        int x0 = (t % r->tiles_x) * r->tile, y0 = (t / r->tiles_x) * r->tile;
        int w = rs->xres - x0 < r->tile ? rs->xres - x0 : r->tile;
        int h = rs->yres - y0 < r->tile ? rs->yres - y0 : r->tile;
        err_t err;
        render_stats_t st = {0};
        tilebuf_t *buf = tilebuf_new(x0, y0, w, h, rs->grid.n, &err);
        int rc = buf ? render_tile(r->scene, x0, y0, w, h, r->sb, r->se, buf, &st, &err) : -1;
        pthread_mutex_lock(&r->lock);
        if (rc == 0)
            rc = tilebuf_merge(r->pass, buf, &err);
        if (rc != 0 && !r->failed) {
            r->failed = 1;
            r->err = err;
        }
        r->stats.samples += st.samples;
        r->stats.rays += st.rays;
        r->stats.nonfinite += st.nonfinite;
        r->stats.dispersive += st.dispersive;
        r->samples_done += (uint64_t)w * (uint64_t)h * (r->se - r->sb);
        progress_update(r->prog, r->samples_before + r->samples_done, r->samples_total, seconds_since(r->t0));
        pthread_mutex_unlock(&r->lock);
        tilebuf_destroy(&buf);
    }
}

/* A pass record of --direct, as the master keeps them (docs/farm.md, "Accuracy"). */
typedef struct direct_pass {
    int pass, spp;
    double elapsed;
    error_estimate_t e;
} direct_pass_t;

/* --direct with a stopping rule: the farm's progressive passes (passes_bounds) on threads
 * of this process. Each pass is rendered tile by tile into a buffer of its own and merged into
 * the image only when whole, in pass order: the per-pixel sums the farm's master makes, bit for
 * bit. After each pass the error estimate decides, as on the master; a time limit drops the
 * pass in flight (after the first). Returns 0 with the passes in hist[*nhist] and why it
 * stopped, or -1 with err. */
static int render_passes(const scene_t *scene, int threads, const cli_stop_t *stop, tilebuf_t *image,
                         progress_t *prog, const struct timespec *t0, render_stats_t *stats,
                         direct_pass_t *hist, int *nhist, proto_stop_t *why, err_t *err)
{
    const render_settings_t *rs = &scene->settings;
    uint32_t bounds[64];
    int npasses = passes_bounds(rs->spp, bounds);
    pass_run_t r = {.scene = scene, .tile = 32, .t0 = t0, .prog = prog,
                    .samples_total = (uint64_t)rs->xres * (uint64_t)rs->yres * (uint64_t)rs->spp};
    r.tiles_x = (rs->xres + r.tile - 1) / r.tile;
    r.ntiles = r.tiles_x * ((rs->yres + r.tile - 1) / r.tile);
    int n = threads > 0 ? threads : local_render_cores();
    if (n > r.ntiles)
        n = r.ntiles;
    pthread_t *th = calloc((size_t)n, sizeof *th);
    if (!th || pthread_mutex_init(&r.lock, NULL)) {
        free(th);
        return err_set(err, "out of memory for %d render threads", n);
    }
    *nhist = 0;
    *why = PROTO_STOP_NONE;
    int rc = 0;
    for (int pass = 0; pass < npasses; pass++) {
        r.sb = bounds[pass];
        r.se = bounds[pass + 1];
        r.next = r.failed = r.abandoned = 0;
        r.samples_done = 0;
        r.stats = (render_stats_t){0};
        r.deadline = pass > 0 ? stop->time_limit : 0; /* the first pass always completes */
        if (!(r.pass = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, err))) {
            rc = -1;
            break;
        }
        int started = 0;
        for (; started < n; started++)
            if (pthread_create(&th[started], NULL, pass_thread, &r))
                break;
        if (started == 0)
            pass_thread(&r); /* no thread could start: render on this one */
        for (int i = 0; i < started; i++)
            pthread_join(th[i], NULL);
        if (r.failed) {
            *err = r.err;
            rc = -1;
        } else if (!r.abandoned) {
            /* The pass's sums rounded as the farm's workers round theirs (tilebuf.h): the
             * rule is per value, so rounding the whole pass equals rounding each tile. */
            tilebuf_round_sums(r.pass);
            rc = tilebuf_merge(image, r.pass, err);
        }
        tilebuf_destroy(&r.pass);
        if (rc || r.abandoned) {
            *why = r.abandoned ? PROTO_STOP_TIME : *why;
            break;
        }
        /* The counters describe the image: a dropped pass's work is not in them. */
        stats->samples += r.stats.samples;
        stats->rays += r.stats.rays;
        stats->nonfinite += r.stats.nonfinite;
        stats->dispersive += r.stats.dispersive;
        r.samples_before += r.samples_done;
        direct_pass_t *h = &hist[(*nhist)++];
        *h = (direct_pass_t){.pass = pass + 1, .spp = (int)bounds[pass + 1], .elapsed = seconds_since(t0),
                             .e = error_estimate_image(image)};
        char extra[96];
        if (h->e.valid)
            snprintf(extra, sizeof extra, "%d spp, rel. error %.4f", h->spp, h->e.rel_rmse);
        else
            snprintf(extra, sizeof extra, "%d spp", h->spp);
        prog->extra = extra;
        progress_update(prog, r.samples_before, r.samples_total, h->elapsed);
        prog->extra = NULL;
        if (pass + 1 == npasses)
            break;
        if (stop->target_error > 0 && h->e.valid && h->e.rel_rmse <= stop->target_error)
            *why = PROTO_STOP_TARGET;
        else if (stop->time_limit > 0 && h->elapsed >= stop->time_limit)
            *why = PROTO_STOP_TIME;
        if (*why != PROTO_STOP_NONE)
            break;
    }
    pthread_mutex_destroy(&r.lock);
    free(th);
    if (rc == 0 && *why != PROTO_STOP_NONE)
        progress_end(prog, r.samples_before, r.samples_total, seconds_since(t0),
                     *why == PROTO_STOP_TARGET ? "target error reached" : "time limit reached");
    return rc;
}

static const char *stop_text(proto_stop_t why)
{
    return why == PROTO_STOP_TARGET ? " (target error reached)"
           : why == PROTO_STOP_TIME ? " (time limit reached)"
                                    : "";
}

/* The same render without the farm: threads of this process over tiles (--direct). */
static int render_direct(const scene_t *scene, const char *scene_path, int threads, int quiet,
                         const cli_stop_t *stop, const char *exr, const char *png,
                         colour_tonemap_t tm, const struct timespec *t0)
{
    static const char *integ_names[] = {"simplepath", "path", "whitted"};
    const render_settings_t *rs = &scene->settings;
    err_t err;
    tilebuf_t *image = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    if (!image) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        return 1;
    }
    progress_t prog = progress_make("render", quiet);
    render_stats_t st = {0};
    int rc = 0;
    direct_pass_t hist[64];
    int nhist = 0;
    proto_stop_t why = PROTO_STOP_NONE;
    struct timespec start;
    clock_gettime(CLOCK_MONOTONIC, &start);
    if (stop->target_error > 0 || stop->time_limit > 0) {
        if (render_passes(scene, threads, stop, image, &prog, &start, &st, hist, &nhist, &why, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        }
    } else {
        local_render_opts_t opts = {.threads = threads, .progress = on_progress, .user = &prog};
        if (local_render(scene, &opts, image, &st, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        }
        /* One record: every pass at once. */
        hist[nhist++] = (direct_pass_t){.pass = passes_bounds(rs->spp, NULL), .spp = rs->spp,
                                        .elapsed = seconds_since(&start), .e = error_estimate_image(image)};
    }
    double secs = seconds_since(t0);
    const direct_pass_t *last = nhist > 0 ? &hist[nhist - 1] : NULL;
    if (rc == 0) {
        /* The accuracy keys as the master writes them (docs/farm.md, "Accuracy"). */
        char info[4096], rel[32] = "none";
        if (last && last->e.valid)
            snprintf(rel, sizeof rel, "%.6g", last->e.rel_rmse);
        int n = snprintf(info, sizeof info,
                 "scene=%s;spp=%d;integrator=%s;dispersion=%s;seed=%llu;samples=%llu;rays=%llu;"
                 "nonfinite=%llu;seconds=%.3f;spp_done=%d;rel_rmse=%s;stop=%s;target_error=%g;"
                 "time_limit=%g;history=",
                 scene_path, rs->spp, integ_names[rs->integrator],
                 scene->has_dispersion ? (rs->dispersion == DISPERSION_HERO ? "hero" : "fanout") : "off",
                 (unsigned long long)rs->seed, (unsigned long long)st.samples,
                 (unsigned long long)st.rays, (unsigned long long)st.nonfinite, secs,
                 last ? last->spp : 0, rel, proto_stop_name(why), stop->target_error, stop->time_limit);
        for (int i = 0; i < nhist && n > 0 && (size_t)n < sizeof info; i++) {
            char e[32] = "-";
            if (hist[i].e.valid)
                snprintf(e, sizeof e, "%.6g", hist[i].e.rel_rmse);
            n += snprintf(info + n, sizeof info - (size_t)n, "%s%d:%d:%.3f:%s", i ? "," : "",
                          hist[i].pass, hist[i].spp, hist[i].elapsed, e);
        }
        film_output_t fo = {.exr_path = exr, .png_path = png, .spectral = 1, .tonemap = tm, .info = info};
        if (film_write(image, rs->grid, &fo, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        } else {
            printf("wrote %s (spectral, %d buckets) and %s\n", exr, rs->grid.n, png);
            printf("%llu samples, %.1f M rays in %.2f s (%.2f M rays/s); %llu non-finite samples discarded\n",
                   (unsigned long long)st.samples, st.rays / 1e6, secs, st.rays / 1e6 / (secs > 0 ? secs : 1),
                   (unsigned long long)st.nonfinite);
            if (last && last->e.valid)
                printf("%d of %d spp, relative error estimate %.4f%s\n", last->spp, rs->spp,
                       last->e.rel_rmse, stop_text(why));
            else if (last)
                printf("%d of %d spp, no relative error estimate%s%s\n", last->spp, rs->spp,
                       last->spp < 2 ? " (1 sample per pixel)" : "", stop_text(why));
            photon_stats_t pst;
            double psec;
            const photon_store_t *ps = rs->photon.enabled ? photon_pass_get(scene, &pst, &psec, &err) : NULL;
            if (ps)
                printf("photon pass: %llu photons in %.2f s, %zu %s (%.1f MB)\n", (unsigned long long)pst.emitted,
                       psec, photon_store_count(ps),
                       photon_store_kind(ps) == PHOTON_STORE_LIGHTMAP ? "texels lit" : "stored",
                       photon_store_memory_bytes(ps) / 1e6);
        }
    }
    tilebuf_destroy(&image);
    return rc;
}

int cmd_render(int argc, char **argv)
{
    const char *scene_path = NULL, *output = NULL;
    scene_overrides_t ov = {.seed = -1};
    cli_stop_t stop = {0};
    long long threads = 0, workers = 1, tile = 0;
    int direct = 0;
    double exposure = 0;
    int quiet = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--quiet")) {
            quiet = 1;
            continue;
        }
        if (!strcmp(a, "--direct")) {
            direct = 1;
            continue;
        }
        if (a[0] == '-' && a[1]) {
            if (i + 1 >= argc) {
                fprintf(stderr, "prismfarm render: %s needs a value\n", a);
                return 2;
            }
            const char *val = argv[++i];
            int handled = cli_parse_override("render", a, val, &ov);
            if (!handled)
                handled = cli_parse_stop("render", a, val, &stop);
            if (handled < 0)
                return 2;
            if (handled)
                continue;
            if (!strcmp(a, "-o") || !strcmp(a, "--output"))
                output = val;
            else if (!strcmp(a, "--threads")) {
                if (cli_parse_int("render", a, val, 1, 1024, &threads))
                    return 2;
            } else if (!strcmp(a, "--workers")) {
                if (cli_parse_int("render", a, val, 1, 64, &workers))
                    return 2;
            } else if (!strcmp(a, "--tile")) {
                if (cli_parse_int("render", a, val, 1, 4096, &tile))
                    return 2;
            } else if (!strcmp(a, "--exposure")) {
                char *end;
                exposure = strtod(val, &end);
                if (end == val || *end || exposure < -30 || exposure > 30) {
                    fprintf(stderr, "prismfarm render: --exposure expects stops in -30..30, got '%s'\n", val);
                    return 2;
                }
            } else {
                fprintf(stderr, "prismfarm render: unknown option '%s' (see prismfarm render --help)\n", a);
                return 2;
            }
            continue;
        }
        if (scene_path) {
            fprintf(stderr, "prismfarm render: more than one scene given ('%s' and '%s')\n", scene_path, a);
            return 2;
        }
        scene_path = a;
    }
    if (!scene_path) {
        usage(stderr);
        return 2;
    }

    err_t err;
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    scene_t *scene = scene_load_file(scene_path, &ov, &err);
    if (!scene) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        return 1;
    }
    const render_settings_t *rs = &scene->settings;

    char exr[PATH_MAX], png[PATH_MAX];
    if (output)
        snprintf(exr, sizeof exr, "%s", output);
    else if (rs->filename[0])
        snprintf(exr, sizeof exr, "%s", rs->filename);
    else {
        const char *base = strrchr(scene_path, '/');
        base = base ? base + 1 : scene_path;
        size_t n = strlen(base);
        if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
            n -= 5;
        snprintf(exr, sizeof exr, "%.*s.exr", (int)n, base);
    }
    film_png_path(exr, png, sizeof png);
    if (make_parent_dirs(exr)) {
        fprintf(stderr, "prismfarm render: cannot create the folder for %s: %s\n", exr, strerror(errno));
        scene_destroy(&scene);
        return 1;
    }

    static const char *integ_names[] = {"simplepath", "path", "whitted"};
    if (!quiet) {
        fprintf(stderr, "render: %s, %dx%d, %d spp, integrator %s, %d buckets over %g-%g nm\n", scene_path,
                rs->xres, rs->yres, rs->spp, integ_names[rs->integrator], rs->grid.n,
                rs->grid.lambda_min, rs->grid.lambda_max);
        if (rs->photon.enabled)
            fprintf(stderr, "render: photon integrator: %llu photons into a photon map, gathered by %s\n",
                    (unsigned long long)rs->photon.photons, integ_names[rs->integrator]);
        if (scene->has_dispersion) {
            fprintf(stderr, "render: dispersion on (%s) for:", rs->dispersion == DISPERSION_HERO ? "hero wavelengths" : "thesis fan-out");
            for (size_t i = 0; i < scene->nmaterials; i++)
                if (scene->materials[i].dispersive)
                    fprintf(stderr, " '%s'", scene->materials[i].name);
            fputc('\n', stderr);
        } else {
            fprintf(stderr, "render: dispersion off: no material's index varies over %g-%g nm\n",
                    rs->grid.lambda_min, rs->grid.lambda_max);
        }
    }

    int rc = 0;
    colour_tonemap_t tm = {.exposure_stops = exposure, .curve = COLOUR_CURVE_ACES};
    if (direct) {
        rc = render_direct(scene, scene_path, (int)threads, quiet, &stop, exr, png, tm, &t0);
    } else {
        /* The farm's code path: a master and workers in this process. */
        const char *base = strrchr(scene_path, '/');
        base = base ? base + 1 : scene_path;
        char name[256];
        size_t n = strlen(base);
        if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
            n -= 5;
        snprintf(name, sizeof name, "%.*s", (int)n, base);
        int cores = local_render_cores();
        /* The master writes its PNG with no exposure change: fetching it saves decoding the
         * EXR and encoding the PNG again; another exposure is tone-mapped here from the EXR. */
        bool master_png = exposure == 0;
        local_farm_opts_t lo = {.scene = scene_path, .name = name, .exr_path = exr,
                                .png_path = master_png ? png : NULL, .overrides = ov,
                                .workers = (int)workers,
                                .threads = threads ? (int)threads : (cores / (int)workers > 0 ? cores / (int)workers : 1),
                                .tile = (int)tile, .quiet = quiet,
                                .target_error = stop.target_error, .time_limit = stop.time_limit};
        proto_job_info_t info;
        rc = local_farm_run(&lo, &info);
        if (rc == 0 && !master_png && film_png_from_exr(exr, png, tm, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        }
        if (rc == 0) {
            printf("wrote %s (spectral, %d buckets) and %s\n", exr, rs->grid.n, png);
            printf("%llu samples in %.2f s (%.2f Msamples/s) on %d worker%s; %llu non-finite samples discarded\n",
                   (unsigned long long)info.samples_done, info.elapsed,
                   info.samples_done / 1e6 / (info.elapsed > 0 ? info.elapsed : 1), (int)workers,
                   workers == 1 ? "" : "s", (unsigned long long)info.nonfinite);
            if (info.has_rel_error)
                printf("%u of %d spp, relative error estimate %.4f%s\n", info.spp, rs->spp,
                       info.rel_error, stop_text(info.stop));
            else
                printf("%u of %d spp, no relative error estimate%s%s\n", info.spp, rs->spp,
                       info.spp < 2 ? " (1 sample per pixel)" : "", stop_text(info.stop));
        }
    }
    scene_destroy(&scene);
    return rc;
}
