/* prismfarm render: renders a scene on this machine's cores and writes the spectral EXR and a
 * PNG preview. */
#include "commands.h"

#include "adaptive.h"
#include "cli_args.h"
#include "cli_warn.h"
#include "clock.h"
#include "error_estimate.h"
#include "film.h"
#include "frame_list.h"
#include "frame_pattern.h"
#include "image_exr.h"
#include "job_follow.h"
#include "jobinfo.h"
#include "local_farm.h"
#include "local_render.h"
#include "pbrt_parser.h"
#include "photon_pass.h"
#include "plan.h"
#include "polar_pilot.h"
#include "polar_seq.h"
#include "pool.h"
#include "progress.h"
#include "scene_bundle.h"
#include "scene_load.h"
#include "settings.h"

#include <errno.h>
#include <limits.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The wire's reasons for an early end are film/stopping.h's, value for value. */
_Static_assert((int)PROTO_STOP_TARGET == (int)STOPPING_TARGET &&
                   (int)PROTO_STOP_TIME == (int)STOPPING_TIME,
               "proto_stop_t and stopping_why_t differ");

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm render SCENE.pbrt [options]\n"
            "       prismfarm render FRAME.pbrt FRAME.pbrt ... [-o 'out/f%%04d.exr'] [options]\n"
            "       prismfarm render 'frame%%04d.pbrt' --frames FIRST-LAST [options]\n"
            "\n"
            "Renders SCENE on this machine through the farm's code path (a master and workers in\n"
            "this process over inproc://); writes a spectral OpenEXR (Fichet et al. layout, float32,\n"
            "with linear sRGB R,G,B channels) and a tone-mapped PNG preview beside it.\n"
            "A frame sequence (several files, or a pattern with --frames) is one job of that farm,\n"
            "each frame's pixels those it has rendered alone with the polarisation decided once\n"
            "for the whole sequence (docs/plan.md); a frame's number is the last number in its\n"
            "file name (else its place in the list, from 1), and -o takes a pattern.\n"
            "Options override the scene file:\n");
    cli_args_help(out, opts);
}

/* --direct's progress lines: the photon pass's, then the camera pass's, whose clock starts
 * when the photons end (as `submit --wait`'s does), though the job's own clock (a --time-limit)
 * runs from the start. */
typedef struct direct_lines {
    progress_t camera, photons;
    double start;          /* the photon pass's start */
    double photon_seconds; /* subtracted from the job's elapsed time on the camera line */
} direct_lines_t;

static void on_photons(void *user, uint64_t done, uint64_t total)
{
    direct_lines_t *d = user;
    char extra[96];
    snprintf(extra, sizeof extra, "%" PRIu64 " of %" PRIu64 " photons", done, total);
    d->photons.extra = extra;
    progress_update(&d->photons, done, total, clock_now_s() - d->start);
    d->photons.extra = NULL;
}

static void on_progress(void *user, uint64_t done, uint64_t total, double elapsed)
{
    direct_lines_t *d = user;
    progress_update(&d->camera, done, total, elapsed - d->photon_seconds);
}

/* The progress line of --direct under a stopping rule: the spp and estimate of each pass. */
static void on_pass(void *user, const pass_record_t *rec, uint64_t done, uint64_t total)
{
    direct_lines_t *d = user;
    progress_t *prog = &d->camera;
    const double elapsed = rec->elapsed - d->photon_seconds;
    char extra[160];
    if (rec->valid)
        progress_note_error(prog, rec->spp, elapsed, rec->rel_error);
    if (rec->valid)
        snprintf(extra, sizeof extra, "%d spp, rel. error %.4f%s", rec->spp, rec->rel_error,
                 error_estimate_note(rec->rel_error));
    else
        snprintf(extra, sizeof extra, "%d spp", rec->spp);
    prog->extra = extra;
    progress_update(prog, done, total, elapsed);
    prog->extra = NULL;
}

/* The header's "why" for an integrator the plan chose (auto, or bdpt and its kin, whose photon
 * pass is the plan's): one line naming the lights that decided the photon pass, the plan's own
 * words being `prismfarm plan`'s. The plan reads the scene, never its integrator settings, so
 * planning the loaded scene again gives the choice scene_load applied (plan.h). */
static void plan_why(const scene_t *scene, const plan_request_t *req, const char *scene_path)
{
    err_t err;
    plan_t *p = plan_new(scene, req, &err);
    if (!p)
        return;
    const plan_choice_t c = plan_choice(p);
    char lights[400] = "";
    size_t n = 0, nadvised = 0, nneeded = 0;
    for (size_t i = 0; i < plan_light_count(p); i++) {
        const plan_light_t *l = plan_light_at(p, i);
        if (l->verdict == PLAN_LIGHT_NOT_NEEDED)
            continue;
        nadvised += l->verdict == PLAN_LIGHT_ADVISED;
        nneeded += l->verdict == PLAN_LIGHT_NEEDED;
        if (n < sizeof lights)
            n += (size_t)snprintf(lights + n, sizeof lights - n, "%slight %d (%s)", n ? ", " : "",
                                  l->index, plan_light_kind_name(l->kind));
    }
    if (c.photon)
        fprintf(stderr,
                "render: why: a photon pass for %s: %s%s%s (`prismfarm plan %s` says more)\n",
                lights, nneeded ? "light that path tracing cannot find (delta or collimated)" : "",
                nneeded && nadvised ? "; " : "",
                nadvised ? "small and bright behind glass, fireflies for path tracing" : "",
                scene_path);
    else
        fprintf(stderr,
                "render: why: no photon pass: path tracing finds every light's caustics "
                "(`prismfarm plan %s` says more)\n",
                scene_path);
    plan_destroy(&p);
}

/* " (target error reached)" after the spp line of a job that stopped early, else "". */
static const char *stop_text(proto_stop_t why, char *buf, size_t size)
{
    const char *r = stopping_reason((stopping_why_t)why);
    snprintf(buf, size, "%s%s%s", *r ? " (" : "", r, *r ? ")" : "");
    return buf;
}

/* The adaptive summary of an EXR the master wrote (its record's tile_spp), when it has one. */
static void print_adaptive(const char *exr)
{
    err_t err;
    image_exr_t *img = image_exr_read(exr, &err);
    const char *info = img ? image_exr_attribute(img, "prismfarm") : NULL;
    tilegrid_t grid;
    int *tile_spp = NULL;
    if (info && jobinfo_tile_spp(info, &grid, &tile_spp, &err) == 1) {
        adaptive_summary_t s = adaptive_summarize(&grid, tile_spp);
        char line[160];
        adaptive_summary_line(&s, line, sizeof line);
        printf("%s\n", line);
    }
    free(tile_spp);
    image_exr_destroy(&img);
}

/* The same render without the farm: the photon pass, if any, then the camera pass on this
 * process's threads (render/local_render.h; --direct). */
static int render_direct(const scene_t *scene, const char *scene_path, int threads, int tile,
                         int quiet, const proto_settings_t *stop, const char *exr, const char *png,
                         colour_tonemap_t tm, double loaded, double load_s)
{
    const render_settings_t *rs = &scene->settings;
    err_t err;
    tilebuf_t *image = tilebuf_new(0, 0, rs->xres, rs->yres, render_settings_buckets(rs), &err);
    if (!image) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        return 1;
    }
    direct_lines_t lines = {.camera = progress_make("render", quiet),
                            .photons = progress_make("photons", quiet)};
    lines.photons.unit = "photons";
    progress_t *prog = &lines.camera;
    if (stop->target_error > 0.0)
        progress_follow_error(prog, stop->target_error, rs->spp);
    render_stats_t st = {0};
    int rc = 0;
    double start = clock_now_s();
    lines.start = start;
    photon_stats_t pst = {0};
    double psec = 0;
    photon_store_t *photons = NULL;
    if (rs->photon.enabled &&
        !(photons = photon_pass_run_reporting(scene, threads, &pst, &psec, on_photons, &lines,
                                              &err))) {
        fprintf(stderr, "prismfarm render: photon pass: %s\n", err.msg);
        tilebuf_destroy(&image);
        return 1;
    }
    lines.photon_seconds = photons ? clock_now_s() - start : 0.0;
    /* The tile size is the farm's (--tile): adaptive sampling decides tile by tile. */
    local_render_opts_t opts = {.threads = threads, .tile_size = tile, .photons = photons, .t0 = start,
                                .stop = {.target_error = stop->target_error,
                                         .time_limit = stop->time_limit},
                                .adaptive = stop->adaptive != 0,
                                .progress = on_progress, .pass_done = on_pass, .user = &lines};
    local_render_result_t res;
    if (local_render(scene, &opts, image, &st, &res, &err)) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        rc = 1;
    } else if (res.why != STOPPING_NONE) {
        progress_end(prog, st.samples, (uint64_t)rs->xres * (uint64_t)rs->yres * (uint64_t)rs->spp,
                     clock_now_s() - start - lines.photon_seconds, stopping_reason(res.why));
    }
    /* From the loaded scene on (photon pass, camera pass, outputs); the load is printed apart. */
    double secs = clock_now_s() - loaded;
    const pass_record_t *last = rc == 0 && res.nhistory > 0 ? &res.history[res.nhistory - 1] : NULL;
    char stop_buf[64];
    if (rc == 0) {
        /* The record the master writes (docs/farm.md, "Accuracy"), from the same writer. */
        char info[16384];
        jobinfo_t ji = {.scene = scene_path, .spp = rs->spp, .xres = rs->xres, .yres = rs->yres,
                        .seed = rs->seed,
                        .integrator = integrators_used_name(rs->integrator, rs->photon.enabled, rs->media),
                        .dispersion = integrators_dispersion_used(rs->dispersion,
                                                                  scene->has_dispersion),
                        .samples = st.samples, .nonfinite = st.nonfinite,
                        .photons = pst.emitted, .rays = (int64_t)st.rays, .seconds = secs,
                        .spp_done = last ? last->spp : 0, .stop = res.why,
                        .rule = opts.stop, .history = res.history, .nhistory = res.nhistory,
                        .tile_spp = res.tile_spp, .grid = res.grid};
        jobinfo_format(&ji, info, sizeof info);
        film_output_t fo = {.exr_path = exr, .png_path = png, .spectral = 1, .tonemap = tm, .info = info};
        if (film_write(image, rs->grid, &fo, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        } else {
            printf("wrote %s (spectral, %d buckets) and %s\n", exr, rs->grid.n, png);
            printf("loaded in %.2f s; %llu samples, %.1f M rays in %.2f s (%.2f M rays/s); %llu non-finite samples discarded\n",
                   load_s, (unsigned long long)st.samples, st.rays / 1e6, secs, st.rays / 1e6 / (secs > 0 ? secs : 1),
                   (unsigned long long)st.nonfinite);
            proto_stop_t why = (proto_stop_t)res.why;
            if (last && last->valid)
                printf("%d of %d spp, relative error estimate %.4f%s%s\n", last->spp, rs->spp,
                       last->rel_error, error_estimate_note(last->rel_error), stop_text(why, stop_buf, sizeof stop_buf));
            else if (last)
                printf("%d of %d spp, no relative error estimate%s%s\n", last->spp, rs->spp,
                       last->spp < 2 ? " (1 sample per pixel)" : "", stop_text(why, stop_buf, sizeof stop_buf));
            char prediction[256];
            /* The last pass may meet the target as the spp cap ends the job. */
            int reached = res.why == STOPPING_TARGET ||
                          (last && last->valid && last->rel_error <= stop->target_error);
            if (last && progress_prediction_line(prog, reached, last->spp,
                                                 last->elapsed - lines.photon_seconds, prediction,
                                                 sizeof prediction))
                printf("%s\n", prediction);
            if (res.tile_spp) {
                adaptive_summary_t as = adaptive_summarize(&res.grid, res.tile_spp);
                char line[160];
                adaptive_summary_line(&as, line, sizeof line);
                printf("%s\n", line);
            }
            if (photons)
                printf("photon pass: %llu photons in %.2f s, %zu %s (%.1f MB)\n", (unsigned long long)pst.emitted,
                       psec, photon_store_count(photons),
                       photon_store_kind(photons) == PHOTON_STORE_LIGHTMAP ? "texels lit" : "stored",
                       photon_store_memory_bytes(photons) / 1e6);
        }
    }
    local_render_result_free(&res);
    photon_store_destroy(&photons);
    tilebuf_destroy(&image);
    return rc;
}

/* What every frame of one `render` command is rendered with. */
typedef struct render_cfg {
    const char *output; /* -o, of one scene (a sequence's outputs are named before) */
    proto_settings_t job; /* the scene overrides and stopping rules */
    long long threads, workers, tile;
    int direct, quiet;
    double exposure;
} render_cfg_t;

static int render_scene(const render_cfg_t *c, const char *scene_path, const char *seq_exr,
                        const char *seq_png, const polar_seq_t *seq_polar);

/* A frame loaded as render_scene loads it. NULL with err. */
static scene_t *load_frame_scene(const render_cfg_t *c, const char *path, err_t *err)
{
    const scene_overrides_t ov = settings_to_overrides(&c->job);
    scene_desc_t *desc = pbrt_parse_file_opts(
        path, &(pbrt_parse_opts_t){.threads = ov.threads, .bundle = !c->direct}, err);
    scene_t *scene = desc ? scene_load(desc, &ov, err) : NULL;
    scene_desc_destroy(&desc);
    return scene;
}

/* A sequence rendered frame by frame (--direct, or frames of several folders) decides its
 * polarisation once, as the master decides a submitted sequence (polar_seq.h, the same frames
 * measured by the same pilot): each frame loaded, its part taken, and dropped -- a second load
 * of every frame, the price of one decision before the first frame renders. Returns 0, or 1
 * with a message. */
static int render_frames_polar(const render_cfg_t *c, const frame_list_t *fl, polar_seq_t *out)
{
    *out = polar_seq_make(c->job.target_error);
    for (size_t k = 0; k < fl->n; k++) {
        err_t err;
        scene_t *scene = load_frame_scene(c, fl->paths[k], &err);
        polar_decision_t d;
        if (!scene || polar_seq_frame(scene, polar_seq_pilots(k, fl->n), c->job.target_error, &d,
                                      &err) < 0) {
            fprintf(stderr, "prismfarm render: frame %u (%s): %s%s\n", fl->numbers[k],
                    fl->paths[k], scene ? "the polarisation pilot: " : "", err.msg);
            scene_destroy(&scene);
            return 1;
        }
        scene_destroy(&scene);
        polar_seq_add(out, k, &d);
    }
    return 0;
}

/* The sequence as one job of the in-process farm (local_farm.h): one bundle with the files the
 * frames share once, the master loading the frames (several at once) and the workers rendering
 * the tiles of every frame; each frame's pixels are those of its render alone (the farm's "Same
 * pixels"). The outputs, named and checked by the caller, are exr[k] and png[k]. */
static int render_frames_farm(const render_cfg_t *c, const frame_list_t *fl, const char *pattern,
                              char (*exr)[4096], char (*png)[4200])
{
    int cores = pool_cores();
    bool master_png = c->exposure == 0;
    local_farm_opts_t lo = {
        .settings = c->job,
        .workers = (int)c->workers,
        .threads = c->threads ? (int)c->threads
                              : (cores / (int)c->workers > 0 ? cores / (int)c->workers : 1),
        .tile = (int)c->tile,
        .quiet = c->quiet,
        .frames = (const char *const *)fl->paths,
        .numbers = fl->numbers,
        .nframes = fl->n,
        .frame_pattern = pattern};
    char name[420];
    frame_list_name(fl, name, sizeof name);
    lo.name = name;
    proto_job_info_t info;
    int rc = local_farm_run(&lo, &info, NULL);
    /* Another exposure: each frame's PNG tone-mapped here from its EXR, as for one scene. */
    colour_tonemap_t tm = {.exposure_stops = c->exposure, .curve = COLOUR_CURVE_ACES};
    err_t err;
    for (size_t k = 0; rc == 0 && !master_png && k < fl->n; k++)
        if (film_png_from_exr(exr[k], png[k], tm, &err)) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        }
    if (rc == 0)
        printf("%zu frames written; %llu samples in %.2f s (%.2f Msamples/s) on %d worker%s; %llu "
               "non-finite samples discarded\n",
               fl->n, (unsigned long long)info.samples_done, info.elapsed,
               info.samples_done / 1e6 / (info.elapsed > 0 ? info.elapsed : 1), (int)c->workers,
               c->workers == 1 ? "" : "s", (unsigned long long)info.nonfinite);
    return rc;
}

/* A frame sequence: every frame's outputs named (job_follow_frame_paths, as `submit --wait`
 * names them) and checked before the first frame is rendered; then each frame rendered as
 * `prismfarm render FRAME -o ITS.exr --polarized D` renders it alone, D the sequence's one
 * polarisation decision (polar_seq.h), so its bytes are the same. */
static int render_frames(const render_cfg_t *c, const frame_list_t *fl, const char *pattern)
{
    err_t err;
    if (pattern && frame_pattern_check(pattern, &err) < 0) {
        fprintf(stderr, "prismfarm render: -o for a sequence of frames: %s\n", err.msg);
        return 2;
    }
    char (*exr)[4096] = calloc(fl->n, sizeof *exr), (*png)[4200] = calloc(fl->n, sizeof *png);
    int rc = 0;
    if (!exr || !png) {
        fprintf(stderr, "prismfarm render: out of memory\n");
        rc = 1;
    }
    for (size_t k = 0; rc == 0 && k < fl->n; k++) {
        proto_job_info_t f = {.name = fl->paths[k], .frame = fl->numbers[k]};
        if (job_follow_frame_paths(&f, pattern, exr[k], sizeof exr[k], png[k], sizeof png[k], &err) < 0) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 2;
        } else {
            rc = job_follow_check_outputs(exr[k], png[k], "render");
        }
        /* Two frames written to one file: a pattern without the number's digits in it. */
        for (size_t i = 0; rc == 0 && i < k; i++)
            if (!strcmp(exr[i], exr[k])) {
                fprintf(stderr, "prismfarm render: frames %u and %u would both be written to %s\n",
                        fl->numbers[i], fl->numbers[k], exr[k]);
                rc = 2;
            }
    }
    /* One bundle holds frames of one folder (scene_bundle.h); frames from several folders are
     * rendered one after another, each in a farm of its own, as --direct renders them. */
    bool one_folder = scene_bundle_one_folder((const char *const *)fl->paths, fl->n);
    if (rc == 0 && !c->direct && one_folder) {
        rc = render_frames_farm(c, fl, pattern, exr, png);
        free(exr);
        free(png);
        return rc;
    }
    polar_seq_t polar, *seq_polar = NULL;
    if (rc == 0 && c->job.polarized == SCENE_POLARIZED_FILE) {
        rc = render_frames_polar(c, fl, &polar);
        seq_polar = &polar;
        if (rc == 0 && !c->quiet) {
            char why[512];
            polar_seq_why(&polar, fl->numbers, why, sizeof why);
            fprintf(stderr, "render: %s\n", why);
        }
    }
    for (size_t k = 0; rc == 0 && k < fl->n; k++) {
        if (!c->quiet)
            fprintf(stderr, "render: frame %u (%zu of %zu): %s\n", fl->numbers[k], k + 1, fl->n,
                    fl->paths[k]);
        if ((rc = render_scene(c, fl->paths[k], exr[k], png[k], seq_polar)) != 0)
            fprintf(stderr, "prismfarm render: frame %u (%s) failed; %zu of %zu frames written\n",
                    fl->numbers[k], fl->paths[k], k, fl->n);
    }
    if (rc == 0)
        printf("%zu frames written\n", fl->n);
    free(exr);
    free(png);
    return rc;
}

int cmd_render(int argc, char **argv)
{
    const char *output = NULL, *range = NULL;
    proto_settings_t job = PROTO_SETTINGS_FILE;
    long long threads = 0, workers = 1, tile = 0;
    int direct = 0;
    double exposure = 0;
    int quiet = 0;
    const cli_opt_t opts[] = {
        {.name = "output",
         .letter = 'o',
         .kind = CLI_STRING,
         .dst = &output,
         .arg = "OUT.exr",
         .help = "output file (default: the Film's filename, else SCENE.exr); a sequence: a "
                 "pattern such as out/f%04d.exr (default: each frame file's name with .exr)"},
        CLI_OPT_FRAMES(.dst = &range),
        CLI_OPT_GROUP(CLI_OVERRIDE_OPTS, .dst = &job),
        CLI_OPT_GROUP(CLI_STOP_OPTS, .dst = &job),
        {.name = "threads",
         .kind = CLI_LLONG,
         .dst = &threads,
         .lo = 1,
         .hi = 1024,
         .arg = "N",
         .help = "render threads per worker (default: all cores / workers)"},
        {.name = "workers",
         .kind = CLI_LLONG,
         .dst = &workers,
         .lo = 1,
         .hi = 64,
         .arg = "N",
         .help = "workers in this process (default 1)"},
        {.name = "tile",
         .kind = CLI_LLONG,
         .dst = &tile,
         .lo = 1,
         .hi = 4096,
         .arg = "N",
         .help = "tile size in pixels (default 32)"},
        {.name = "direct",
         .kind = CLI_FLAG,
         .dst = &direct,
         .help = "render on this process's threads, without the farm's master and workers: the "
                 "same passes, rounding and merge order, so the same pixels (docs/farm.md, "
                 "\"Same pixels\")"},
        {.name = "exposure",
         .kind = CLI_DOUBLE,
         .dst = &exposure,
         .lo = -30,
         .hi = 30,
         .unit = "stops",
         .arg = "STOPS",
         .help = "preview exposure (default 0)"},
        CLI_OPT_QUIET(.dst = &quiet, .help = "no progress output"),
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "render", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (first == argc) {
        usage(stderr, opts);
        return 2;
    }
    frame_list_t fl;
    int rc = frame_list_parse(&fl, argv + first, (size_t)(argc - first), range, "render");
    render_cfg_t c = {.output = output,
                      .job = job,
                      .threads = threads,
                      .workers = workers,
                      .tile = tile,
                      .direct = direct,
                      .quiet = quiet,
                      .exposure = exposure};
    if (rc == 0)
        rc = fl.sequence ? render_frames(&c, &fl, output)
                         : render_scene(&c, fl.paths[0], NULL, NULL, NULL);
    frame_list_free(&fl);
    return rc;
}

static int render_scene(const render_cfg_t *c, const char *scene_path, const char *seq_exr,
                        const char *seq_png, const polar_seq_t *seq_polar)
{
    const char *output = c->output;
    const scene_overrides_t ov = settings_to_overrides(&c->job);
    const proto_settings_t *stop = &c->job; /* the stopping rules (polarized: job, below) */
    const long long threads = c->threads, workers = c->workers, tile = c->tile;
    const int quiet = c->quiet;
    const double exposure = c->exposure;
    err_t err;
    /* The load (parse, meshes, textures, Embree's build) is timed apart from the render. */
    double t0 = clock_now_s();
    /* Without --direct the scene goes to the farm: the bundle rule applies before any file is
     * read (pbrt_confine.h), so the refusal is the one submit and check give. */
    scene_desc_t *desc = pbrt_parse_file_opts(
        scene_path, &(pbrt_parse_opts_t){.threads = ov.threads, .bundle = !c->direct}, &err);
    scene_t *scene = desc ? scene_load(desc, &ov, &err) : NULL;
    /* The request as the plan saw it, for the header's "why" (plan_why). */
    const plan_request_t plan_req = desc ? plan_request_make(desc, &ov) : (plan_request_t){0};
    scene_desc_destroy(&desc);
    if (!scene) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        return 1;
    }
    /* Polarised transport decided once, before the job starts, by the rule the master applies
     * to a submitted job (render/polar_pilot.h): --direct renders with it, the in-process farm
     * gets it as the job's setting and every worker obeys it. */
    proto_settings_t job = c->job;
    polar_decision_t polar = {0};
    if (seq_polar) {
        /* A frame of a sequence: the sequence's decision (render_frames_polar), as its job's
         * setting and on the loaded scene. */
        polar.setting = seq_polar->setting;
        polar_pilot_record(scene, &polar);
        job.polarized = polar.setting;
    } else if (job.polarized == SCENE_POLARIZED_FILE) {
        if (polar_pilot_decide(scene, job.target_error, &polar, &err) < 0) {
            fprintf(stderr, "prismfarm render: the polarisation pilot: %s\n", err.msg);
            scene_destroy(&scene);
            return 1;
        }
        polar_pilot_record(scene, &polar);
        job.polarized = polar.setting;
    } else {
        scene->settings.polar_pilot.forced = 1; /* --polarized on|off: the user's */
    }
    const double loaded = clock_now_s(), load_s = loaded - t0;
    cli_warn_print("render", scene->warnings);
    const render_settings_t *rs = &scene->settings;

    char exr[PATH_MAX], png[PATH_MAX];
    int other_format = 0;
    if (seq_exr) {
        snprintf(exr, sizeof exr, "%s", seq_exr);
        snprintf(png, sizeof png, "%s", seq_png);
    } else if (output || rs->filename[0]) {
        const char *name = output ? output : rs->filename;
        film_output_paths(name, exr, sizeof exr, png, sizeof png, &other_format);
        if (other_format)
            fprintf(stderr, "prismfarm render: warning: \"%s\": prismfarm writes OpenEXR and PNG, so "
                            "the image is %s and %s\n", name, exr, png);
    } else {
        const char *base = strrchr(scene_path, '/');
        base = base ? base + 1 : scene_path;
        size_t n = strlen(base);
        if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
            n -= 5;
        snprintf(exr, sizeof exr, "%.*s.exr", (int)n, base);
        film_png_path(exr, png, sizeof png);
    }
    /* Before the render, not after it: a missing folder (never created for the user), one
     * that is not writable, or a device or FIFO at the output's name. */
    int bad_output = job_follow_check_outputs(exr, png, "render");
    if (bad_output) {
        scene_destroy(&scene);
        return bad_output;
    }

    if (!quiet) {
        /* What runs, and what was asked where they differ: "auto" and pbrt-v4's bdpt take the
         * plan's photon pass, volpath is path with media. */
        const char *used = integrators_used_name(rs->integrator, rs->photon.enabled, rs->media);
        char asked[80] = "";
        const integrator_name_t *an = integrators_find(scene->integrator_asked);
        const int same = !strcmp(used, scene->integrator_asked) ||
                         (!strcmp(scene->integrator_asked, "photon") && rs->photon.enabled);
        const int planned = an && (an->plan_photons || !strcmp(an->name, "auto"));
        if (!same && an)
            snprintf(asked, sizeof asked, " (asked: %s%s)", scene->integrator_asked,
                     planned ? ", the plan's choice" : "");
        fprintf(stderr, "render: %s, %dx%d, %d spp, integrator %s%s, %d buckets over %g-%g nm\n",
                scene_path, rs->xres, rs->yres, rs->spp, used, asked, rs->grid.n,
                rs->grid.lambda_min, rs->grid.lambda_max);
        if (planned)
            plan_why(scene, &plan_req, scene_path);
        else if (rs->photon.enabled)
            fprintf(stderr, "render: why: %s asks for photons\n",
                    plan_req.overridden ? "--integrator photon"
                                        : "the scene's Integrator directive");
        if (polar.measured)
            fprintf(stderr,
                    "render: polarisation %s: the plan's pilot measured that ignoring it changes "
                    "the image by %.2f %% (up to %.2f %%), %s the target error of %g %%\n",
                    polar.setting == SCENE_POLARIZED_ON ? "on" : "off", 100.0 * polar.pilot.change,
                    100.0 * polar.pilot.change_hi,
                    polar.setting == SCENE_POLARIZED_ON ? "above" : "within", 100.0 * polar.target);
        if (rs->photon.enabled)
            fprintf(stderr, "render: photon integrator: %llu photons into a photon map, gathered by %s\n",
                    (unsigned long long)rs->photon.photons, integrators_kind_name(rs->integrator));
        const int lens = scene->camera.kind == CAMERA_REALISTIC && scene->camera.lens_dispersive;
        if (scene->has_dispersion || lens) {
            fprintf(stderr, "render: dispersion on (%s) for:", rs->dispersion == DISPERSION_HERO ? "hero wavelengths" : "thesis fan-out");
            for (size_t i = 0; i < scene->nmaterials; i++)
                if (scene->materials[i].dispersive)
                    fprintf(stderr, scene->materials[i].named ? " '%s'" : " %s",
                            scene->materials[i].name);
            if (lens)
                fprintf(stderr, " the camera's lens (its glasses: axial and lateral colour)");
            fputc('\n', stderr);
        } else {
            fprintf(stderr, "render: dispersion off: no material's index varies over %g-%g nm\n",
                    rs->grid.lambda_min, rs->grid.lambda_max);
        }
    }

    int rc = 0;
    colour_tonemap_t tm = {.exposure_stops = exposure, .curve = COLOUR_CURVE_ACES};
    if (c->direct) {
        rc = render_direct(scene, scene_path, (int)threads, (int)tile, quiet, stop, exr, png, tm,
                           loaded, load_s);
    } else {
        /* The farm's code path: a master and workers in this process. */
        const char *base = strrchr(scene_path, '/');
        base = base ? base + 1 : scene_path;
        char name[256];
        size_t n = strlen(base);
        if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
            n -= 5;
        snprintf(name, sizeof name, "%.*s", (int)n, base);
        int cores = pool_cores();
        /* The master writes its PNG with no exposure change: fetching it saves decoding the
         * EXR and encoding the PNG again; another exposure is tone-mapped here from the EXR. */
        bool master_png = exposure == 0;
        local_farm_opts_t lo = {.scene = scene_path,
                                .name = name,
                                .exr_path = exr,
                                .png_path = master_png ? png : NULL,
                                .settings = job,
                                .workers = (int)workers,
                                .threads =
                                    threads ? (int)threads
                                            : (cores / (int)workers > 0 ? cores / (int)workers : 1),
                                .tile = (int)tile,
                                .quiet = quiet,
                                .loaded = scene};
        char prediction[256] = "";
        lo.prediction = prediction;
        lo.prediction_size = sizeof prediction;
        proto_job_info_t info;
        char stop_buf[64];
        rc = local_farm_run(&lo, &info, NULL);
        /* The client's outputs beside the EXR the master wrote: another exposure's PNG, and a
         * Stokes output's polarisation previews (from its S0-S3 layers, as --direct's). */
        if (rc == 0 && ((!master_png && film_png_from_exr(exr, png, tm, &err)) ||
                        film_stokes_previews_from_exr(exr, png, &err))) {
            fprintf(stderr, "prismfarm render: %s\n", err.msg);
            rc = 1;
        }
        if (rc == 0) {
            printf("wrote %s (spectral, %d buckets) and %s\n", exr, rs->grid.n, png);
            printf("loaded in %.2f s; %llu samples in %.2f s (%.2f Msamples/s) on %d worker%s; %llu non-finite samples discarded\n",
                   load_s, (unsigned long long)info.samples_done, info.elapsed,
                   info.samples_done / 1e6 / (info.elapsed > 0 ? info.elapsed : 1), (int)workers,
                   workers == 1 ? "" : "s", (unsigned long long)info.nonfinite);
            if (info.has_rel_error)
                printf("%u of %d spp, relative error estimate %.4f%s%s\n", info.spp, rs->spp,
                       info.rel_error, error_estimate_note(info.rel_error), stop_text(info.stop, stop_buf, sizeof stop_buf));
            else
                printf("%u of %d spp, no relative error estimate%s%s\n", info.spp, rs->spp,
                       info.spp < 2 ? " (1 sample per pixel)" : "", stop_text(info.stop, stop_buf, sizeof stop_buf));
            if (prediction[0])
                printf("%s\n", prediction);
            print_adaptive(exr);
        }
    }
    scene_destroy(&scene);
    return rc;
}
