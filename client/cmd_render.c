/* prismfarm render: renders a scene on this machine's cores and writes the spectral EXR and a
 * PNG preview. */
#include "commands.h"

#include "cli_args.h"
#include "film.h"
#include "local_farm.h"
#include "local_render.h"
#include "photon.h"
#include "progress.h"
#include "scene_load.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

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
            "  --threads N              render threads per worker (default: all cores / workers)\n"
            "  --workers N              workers in this process (default 1)\n"
            "  --tile N                 tile size in pixels (default 32)\n"
            "  --direct                 render with plain threads, without the farm's master and\n"
            "                           workers (same pixels up to rounding; for comparisons)\n"

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

/* The same render without the farm: threads of this process over tiles (--direct). */
static int render_direct(const scene_t *scene, const char *scene_path, int threads, int quiet,
                         const char *exr, const char *png, colour_tonemap_t tm,
                         const struct timespec *t0)
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
    local_render_opts_t opts = {.threads = threads, .progress = on_progress, .user = &prog};
    render_stats_t st = {0};
    int rc = 0;
    if (local_render(scene, &opts, image, &st, &err)) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        rc = 1;
    }
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double secs = (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
    if (rc == 0) {
        char info[512];
        snprintf(info, sizeof info,
                 "scene=%s;spp=%d;integrator=%s;dispersion=%s;seed=%llu;samples=%llu;rays=%llu;"
                 "nonfinite=%llu;seconds=%.3f",
                 scene_path, rs->spp, integ_names[rs->integrator],
                 scene->has_dispersion ? (rs->dispersion == DISPERSION_HERO ? "hero" : "fanout") : "off",
                 (unsigned long long)rs->seed, (unsigned long long)st.samples,
                 (unsigned long long)st.rays, (unsigned long long)st.nonfinite, secs);
        film_output_t fo = {.exr_path = exr, .png_path = png, .spectral = 1, .tonemap = tm, .info = info};
        if (film_write(image, rs->grid, &fo, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        } else {
            printf("wrote %s (spectral, %d buckets) and %s\n", exr, rs->grid.n, png);
            printf("%llu samples, %.1f M rays in %.2f s (%.2f M rays/s); %llu non-finite samples discarded\n",
                   (unsigned long long)st.samples, st.rays / 1e6, secs, st.rays / 1e6 / (secs > 0 ? secs : 1),
                   (unsigned long long)st.nonfinite);
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
        rc = render_direct(scene, scene_path, (int)threads, quiet, exr, png, tm, &t0);
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
        local_farm_opts_t lo = {.scene = scene_path, .name = name, .exr_path = exr, .overrides = ov,
                                .workers = (int)workers,
                                .threads = threads ? (int)threads : (cores / (int)workers > 0 ? cores / (int)workers : 1),
                                .tile = (int)tile, .quiet = quiet};
        proto_job_info_t info;
        rc = local_farm_run(&lo, &info);
        if (rc == 0 && film_png_from_exr(exr, png, tm, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        }
        if (rc == 0) {
            printf("wrote %s (spectral, %d buckets) and %s\n", exr, rs->grid.n, png);
            printf("%llu samples in %.2f s (%.2f Msamples/s) on %d worker%s; %llu non-finite samples discarded\n",
                   (unsigned long long)info.samples_done, info.elapsed,
                   info.samples_done / 1e6 / (info.elapsed > 0 ? info.elapsed : 1), (int)workers,
                   workers == 1 ? "" : "s", (unsigned long long)info.nonfinite);
        }
    }
    scene_destroy(&scene);
    return rc;
}
