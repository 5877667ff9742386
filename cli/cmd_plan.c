/* prismfarm plan: prints what a scene calls for -- wavelength splitting, spectral colour, the
 * dispersion strategy, a photon pass and its parameters, the integrator -- and why, as a
 * readable report or, with --json, as JSON (scene/plan.h; docs/plan.md). */
#include "commands.h"

#include "cli_args.h"
#include "cli_json.h"
#include "cli_warn.h"
#include "clock.h"
#include "frame_list.h"
#include "local_render.h"
#include "pbrt_parser.h"
#include "plan.h"
#include "polar_pilot.h"
#include "polar_seq.h"
#include "pool.h"
#include "predict.h"
#include "scene_load.h"
#include "settings.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm plan SCENE.pbrt [--json] [options]\n"
            "       prismfarm plan FRAME.pbrt ... | 'frame%%04d.pbrt' --frames A-B [options]\n"
            "\n"
            "Prints the effect plan of SCENE: whether paths split their wavelengths (a dispersive\n"
            "material), whether emission or reflectance varies with wavelength, the dispersion\n"
            "strategy, whether a photon pass is needed (a delta, collimated, or small and bright\n"
            "light reaching a mirror or glass that a diffuse surface sees) and its parameters,\n"
            "and the integrator, each with the scene elements that caused it; then what is\n"
            "switched off and why. Integrator \"auto\" (the default when the scene names none)\n"
            "renders with this plan; an explicit integrator is kept and differences are noted.\n"
            "With --target-error E it then renders a short pilot on this machine (--pilot\n"
            "seconds of whole passes, the photon pass first) and predicts the samples per pixel\n"
            "and the time that reach E (the error falls as 1/sqrt(spp): a prediction, docs/plan.md).\n"
            "A frame sequence (as for render and submit) is planned by its first frame, then\n"
            "the polarisation decided once for all its frames is said with its reason.\n"
            "Options override the scene file as for prismfarm render:\n");
    cli_args_help(out, opts);
    fprintf(out, "\n"
                 "exit status: 0 success, 1 the scene cannot be loaded, 2 bad command line\n");
}

static json_t *jstring_or_null(const char *s)
{
    return s && s[0] ? cli_json_string(s) : json_null();
}

static json_t *plan_json(const char *path, const scene_t *scene, const plan_t *p)
{
    const render_settings_t *rs = &scene->settings;
    const plan_request_t *q = plan_request(p);
    plan_choice_t c = plan_choice(p);
    json_t *o = json_object();
    json_object_set_new(o, "scene", cli_json_string(path));

    json_t *req = json_object();
    json_object_set_new(req, "integrator", cli_json_string(q->integrator));
    json_object_set_new(req, "integrator_named", json_boolean(q->integrator_named));
    json_object_set_new(req, "overridden", json_boolean(q->overridden));
    json_object_set_new(req, "dispersion", jstring_or_null(q->dispersion));
    json_object_set_new(o, "request", req);

    json_t *cur = json_object();
    json_object_set_new(cur, "integrator", json_string(integrators_kind_name(rs->integrator)));
    json_object_set_new(cur, "dispersion",
                        json_string(integrators_dispersion_name(rs->dispersion)));
    json_object_set_new(cur, "photon", json_boolean(rs->photon.enabled));
    json_object_set_new(cur, "photons",
                        rs->photon.enabled ? json_integer((json_int_t)rs->photon.photons)
                                           : json_null());
    json_object_set_new(cur, "radius",
                        rs->photon.enabled ? json_real(rs->photon.radius) : json_null());
    json_object_set_new(o, "renders_with", cur);

    json_t *ch = json_object();
    json_object_set_new(ch, "integrator", json_string(integrators_kind_name(c.integrator)));
    json_object_set_new(ch, "dispersion",
                        json_string(integrators_dispersion_name(c.dispersion)));
    json_object_set_new(ch, "photon", json_boolean(c.photon));
    json_object_set_new(ch, "photons",
                        c.photon ? json_integer((json_int_t)c.photons) : json_null());
    json_object_set_new(ch, "radius", c.photon ? json_real(c.radius) : json_null());
    json_object_set_new(ch, "differs_from_request", json_boolean(c.differs));
    json_object_set_new(o, "choice", ch);

    json_t *ds = json_array(), *off = json_array();
    for (size_t i = 0; i < plan_decision_count(p); i++) {
        const plan_decision_t *d = plan_decision_at(p, i);
        json_t *jd = json_object();
        json_object_set_new(jd, "effect", cli_json_string(d->effect_name));
        json_object_set_new(jd, "on", json_boolean(d->on));
        json_object_set_new(jd, "choice", cli_json_string(d->choice));
        json_object_set_new(jd, "reason", cli_json_string(d->reason));
        json_array_append_new(ds, jd);
        if (!d->on)
            json_array_append_new(off, cli_json_string(d->effect_name));
    }
    json_object_set_new(o, "decisions", ds);
    json_object_set_new(o, "switched_off", off);

    json_t *ms = json_array();
    for (size_t i = 0; i < plan_material_count(p); i++) {
        const plan_material_t *m = plan_material_at(p, i);
        json_t *jm = json_object();
        json_object_set_new(jm, "index", json_integer(m->index));
        json_object_set_new(jm, "name", cli_json_string(m->name));
        json_object_set_new(jm, "kind", json_string(material_kind_name(m->kind)));
        json_object_set_new(jm, "dispersive", json_boolean(m->dispersive));
        json_object_set_new(jm, "spectral", json_boolean(m->spectral));
        if (m->kind == MATERIAL_DIELECTRIC) {
            json_object_set_new(jm, "n_lo", json_real(m->n_lo));
            json_object_set_new(jm, "n_mid", json_real(m->n_mid));
            json_object_set_new(jm, "n_hi", json_real(m->n_hi));
            json_object_set_new(jm, "n_d", json_real(m->n_d));
            json_object_set_new(jm, "v_d", m->has_v_d ? json_real(m->v_d) : json_null());
            json_object_set_new(jm, "v_film", m->dispersive ? json_real(m->v_film) : json_null());
        }
        json_array_append_new(ms, jm);
    }
    json_object_set_new(o, "materials", ms);

    json_t *ls = json_array();
    for (size_t i = 0; i < plan_light_count(p); i++) {
        const plan_light_t *l = plan_light_at(p, i);
        json_t *jl = json_object();
        json_object_set_new(jl, "index", json_integer(l->index));
        json_object_set_new(jl, "kind", json_string(plan_light_kind_name(l->kind)));
        json_object_set_new(jl, "shape", l->shape >= 0 ? json_integer(l->shape) : json_null());
        json_object_set_new(jl, "power_share", json_real(l->power_share));
        json_object_set_new(jl, "spectral", json_boolean(l->spectral));
        json_object_set_new(jl, "solid_angle",
                            l->solid_angle >= 0.0 ? json_real(l->solid_angle) : json_null());
        json_object_set_new(jl, "small", json_boolean(l->small));
        json_object_set_new(jl, "bright", json_boolean(l->bright));
        json_object_set_new(jl, "reaches_specular", json_boolean(l->reaches_specular));
        json_object_set_new(jl, "caustic", json_boolean(l->caustic));
        json_object_set_new(jl, "direct", json_boolean(l->direct));
        json_object_set_new(jl, "undecided", json_boolean(l->undecided));
        json_object_set_new(
            jl, "glass",
            l->glass_material >= 0
                ? cli_json_string(plan_material_at(p, (size_t)l->glass_material)->name)
                : json_null());
        json_object_set_new(
            jl, "receiver",
            l->receiver_material >= 0
                ? cli_json_string(plan_material_at(p, (size_t)l->receiver_material)->name)
                : json_null());
        json_object_set_new(jl, "rays", json_integer((json_int_t)l->rays));
        json_object_set_new(jl, "photons", json_string(plan_verdict_name(l->verdict)));
        json_array_append_new(ls, jl);
    }
    json_object_set_new(o, "lights", ls);
    json_object_set_new(o, "rays", json_integer((json_int_t)plan_rays(p)));
    return o;
}

/* One pilot render at spp samples per pixel (the scene's own setting, restored after): the
 * photon pass, then the camera pass's whole passes, stopping early at the target. */
static int pilot_at(scene_t *scene, int spp, double target, local_render_result_t *res,
                    err_t *err)
{
    render_settings_t *rs = &scene->settings;
    const int keep = rs->spp;
    rs->spp = spp;
    tilebuf_t *image = tilebuf_new(0, 0, rs->xres, rs->yres, render_settings_buckets(rs), err);
    int rc = -1;
    if (image) {
        /* local_render traces the photon pass first, inside the records' times. */
        local_render_opts_t o = {.t0 = clock_now_s(), .stop = {.target_error = target}};
        render_stats_t st = {0};
        rc = local_render(scene, &o, image, &st, res, err);
    }
    tilebuf_destroy(&image);
    rs->spp = keep;
    return rc;
}

/* The pilot of --target-error: 2 spp first (two passes, the second with an error estimate),
 * then, when that took well under pilot_s seconds, the most samples per pixel (a power of two,
 * at most the scene's) that its rate fits in pilot_s, so the estimate the prediction starts
 * from is as good as the budget allows. *res gets the last run's pass records. */
static int run_pilot(scene_t *scene, double target, double pilot_s, local_render_result_t *res,
                     err_t *err)
{
    const int cap = scene->settings.spp;
    int spp = cap < 2 ? cap : 2;
    if (pilot_at(scene, spp, target, res, err) < 0)
        return -1;
    if (res->why == STOPPING_TARGET || res->nhistory < 1)
        return 0;
    const double per_spp = res->history[res->nhistory - 1].elapsed / spp;
    int more = spp;
    while (more * 2 <= cap && per_spp * more * 2 <= pilot_s)
        more *= 2;
    return more > spp ? pilot_at(scene, more, target, res, err) : 0;
}

/* The prediction's report, after the plan's. */
static void print_prediction(const scene_t *scene, const local_render_result_t *res,
                             double target)
{
    const int spp = scene->settings.spp;
    predict_t p = predict_target(res->history, res->nhistory, target);
    printf("\nPREDICTION (target error %g, on this machine's %d thread%s)\n", target, pool_cores(),
           pool_cores() == 1 ? "" : "s");
    const pass_record_t *last = res->nhistory > 0 ? &res->history[res->nhistory - 1] : NULL;
    if (!p.valid || !last) {
        printf("  the pilot gave no error estimate (an image with no light, or a single pass)\n");
        return;
    }
    printf("  pilot: %d spp in %.1f s (%.1f s of it before the camera pass's samples: the photon "
           "pass, if any), relative error %.4f\n",
           last->spp, last->elapsed, p.fixed, last->rel_error);
    if (res->why == STOPPING_TARGET) {
        printf("  reached: the pilot's %d spp already bring the error to %.4f <= %g\n", last->spp,
               last->rel_error, target);
        return;
    }
    const int job_spp = predict_pass_spp(&p, spp);
    if (p.spp <= spp)
        printf("  predicted: %g at about %.0f spp, that is %d spp in whole passes, in about "
               "%.0f s (the scene's cap is %d spp)\n",
               target, ceil(p.spp), job_spp, predict_pass_seconds(&p, spp), spp);
    else
        printf("  predicted: %g needs about %.0f spp and %.0f s, past the scene's %d spp, where "
               "the error would be about %.4f: raise --spp to reach the target\n",
               target, ceil(p.spp), p.seconds, spp, p.from_error * sqrt((double)p.from_spp / spp));
    printf("  (the error falls as 1/sqrt(spp); a few passes' estimate is itself noisy, and "
           "adaptive sampling often stops sooner: a prediction, not a promise)\n");
}

static int finish(plan_t **plan, scene_t **scene, scene_desc_t **desc, int rc)
{
    plan_destroy(plan);
    scene_destroy(scene);
    scene_desc_destroy(desc);
    return rc;
}

static json_t *prediction_json(const local_render_result_t *res, double target)
{
    predict_t p = predict_target(res->history, res->nhistory, target);
    json_t *o = json_object();
    json_object_set_new(o, "target_error", json_real(target));
    json_object_set_new(o, "threads", json_integer(pool_cores()));
    json_object_set_new(o, "reached_in_pilot", json_boolean(res->why == STOPPING_TARGET));
    json_object_set_new(o, "pilot_spp", p.valid ? json_integer(p.from_spp) : json_null());
    json_object_set_new(o, "pilot_error", p.valid ? json_real(p.from_error) : json_null());
    json_object_set_new(o, "spp", p.valid ? json_real(p.spp) : json_null());
    json_object_set_new(o, "seconds", p.valid ? json_real(p.seconds) : json_null());
    return o;
}

/* The rest of a sequence's polarisation decision (polar_seq.h, as the master makes it): frame
 * 0's part is d0 (the pilot always measures the first frame); frames 1.. are loaded, their
 * parts taken, and dropped. Returns 0, or 1 with a message. */
static int plan_sequence_polar(const frame_list_t *fl, const scene_overrides_t *ov,
                               double target_error, const polar_decision_t *d0, polar_seq_t *out)
{
    *out = polar_seq_make(target_error);
    polar_seq_add(out, 0, d0);
    for (size_t k = 1; k < fl->n; k++) {
        err_t err;
        scene_desc_t *desc = pbrt_parse_file(fl->paths[k], &err);
        scene_t *scene = desc ? scene_load(desc, ov, &err) : NULL;
        scene_desc_destroy(&desc);
        polar_decision_t d;
        bool pilot = polar_seq_pilots(k, fl->n);
        if (!scene || polar_seq_frame(scene, pilot, target_error, &d, &err) < 0) {
            fprintf(stderr, "prismfarm plan: frame %u (%s): %s%s\n", fl->numbers[k], fl->paths[k],
                    scene ? "the polarisation pilot: " : "", err.msg);
            scene_destroy(&scene);
            return 1;
        }
        scene_destroy(&scene);
        polar_seq_add(out, k, &d);
    }
    return 0;
}

static int plan_frames(const frame_list_t *fl, const proto_settings_t *jobp, int json,
                       double pilot);

int cmd_plan(int argc, char **argv)
{
    int json = 0;
    const char *range = NULL;
    proto_settings_t job = PROTO_SETTINGS_FILE;
    double pilot = 4.0;
    /* The setting's own entry (its bounds and messages), with plan's example and help. */
    cli_opt_t target = *cli_args_setting("target-error");
    target.dst = &job;
    target.example = "e.g. 0.05";
    target.help = "predict the samples and time that reach E from a pilot render";
    const cli_opt_t opts[] = {
        CLI_OPT_JSON(.dst = &json, .help = "print JSON instead of the report"),
        CLI_OPT_FRAMES(.dst = &range),
        target,
        {.name = "pilot",
         .kind = CLI_DOUBLE,
         .dst = &pilot,
         .lo = 0.1,
         .hi = 3600,
         .unit = "seconds",
         .example = "e.g. 4",
         .arg = "S",
         .help = "seconds of pilot render for --target-error (default 4)"},
        CLI_OPT_GROUP(CLI_OVERRIDE_OPTS, .dst = &job),
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "plan", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (first == argc) {
        fprintf(stderr, "prismfarm plan: no scene given\n");
        usage(stderr, opts);
        return 2;
    }
    frame_list_t fl;
    int flrc = frame_list_parse(&fl, argv + first, (size_t)(argc - first), range, "plan");
    /* A file given twice is no sequence (submit and render refuse it as their bundle does). */
    for (size_t k = 1; flrc == 0 && k < fl.n; k++)
        for (size_t i = 0; flrc == 0 && i < k; i++)
            if (!strcmp(fl.paths[i], fl.paths[k])) {
                fprintf(stderr, "prismfarm plan: %s is given twice as a frame\n", fl.paths[k]);
                flrc = 2;
            }
    if (flrc != 0) {
        frame_list_free(&fl);
        return flrc;
    }
    int rc = plan_frames(&fl, &job, json, pilot);
    frame_list_free(&fl);
    return rc;
}

/* The plan of one scene, or of a sequence's first frame followed by the sequence's
 * polarisation decision. */
static int plan_frames(const frame_list_t *fl, const proto_settings_t *jobp, int json,
                       double pilot)
{
    const proto_settings_t job = *jobp;
    const char *path = fl->paths[0];
    const scene_overrides_t ov = settings_to_overrides(&job);
    err_t err;
    scene_desc_t *desc = pbrt_parse_file(path, &err);
    scene_t *scene = desc ? scene_load(desc, &ov, &err) : NULL;
    plan_t *plan = NULL;
    /* Polarisation as a job of this scene would carry it: the one rule the master and
     * `render` apply before a job starts, against the job's target error. */
    polar_decision_t polar;
    /* A sequence: its one decision (polar_seq.h), said after the first frame's plan. */
    char seq_why[512] = "";
    const char *seq_setting = NULL;
    if (scene && job.polarized != SCENE_POLARIZED_FILE) {
        /* --polarized on|off: the user's, no pilot (the scene was loaded with it). */
        scene->settings.polar_pilot.forced = 1;
        seq_setting = job.polarized == SCENE_POLARIZED_ON ? "on" : "off";
        snprintf(seq_why, sizeof seq_why, "polarisation %s for all %zu frames: forced by the user "
                 "(--polarized %s)", seq_setting, fl->n, seq_setting);
    } else {
        if (scene && polar_pilot_decide(scene, job.target_error, &polar, &err) < 0)
            scene_destroy(&scene);
        if (scene)
            polar_pilot_record(scene, &polar);
        polar_seq_t ps;
        if (scene && fl->sequence) {
            if (plan_sequence_polar(fl, &ov, job.target_error, &polar, &ps) != 0)
                return finish(&plan, &scene, &desc, 1);
            polar_seq_why(&ps, fl->numbers, seq_why, sizeof seq_why);
            seq_setting = ps.setting == SCENE_POLARIZED_ON ? "on" : "off";
        }
    }
    if (!fl->sequence)
        seq_setting = NULL;
    if (scene) {
        cli_warn_print("plan", scene->warnings);
        plan_request_t req = plan_request_make(desc, &ov);
        plan = plan_new(scene, &req, &err);
    }
    int rc = 0;
    if (!plan) {
        fprintf(stderr, "prismfarm plan: %s\n", err.msg);
        return finish(&plan, &scene, &desc, 1);
    }
    /* The pilot of --target-error runs after the report is out (it takes seconds). */
    local_render_result_t res;
    const int pilot_asked = job.target_error > 0.0;
    if (json) {
        json_t *o = plan_json(path, scene, plan);
        if (seq_setting) {
            json_t *sq = json_object();
            json_object_set_new(sq, "frames", json_integer((json_int_t)fl->n));
            json_object_set_new(sq, "polarization", json_string(seq_setting));
            json_object_set_new(sq, "why", cli_json_string(seq_why));
            json_object_set_new(o, "sequence", sq);
        }
        if (pilot_asked) {
            if (run_pilot(scene, job.target_error, pilot, &res, &err) < 0) {
                fprintf(stderr, "prismfarm plan: pilot render: %s\n", err.msg);
                json_decref(o);
                return finish(&plan, &scene, &desc, 1);
            }
            json_object_set_new(o, "prediction", prediction_json(&res, job.target_error));
        }
        if (cli_json_print(o, JSON_INDENT(2)) != 0) {
            fprintf(stderr, "prismfarm plan: cannot write JSON\n");
            rc = 1;
        }
        return finish(&plan, &scene, &desc, rc);
    }
    const render_settings_t *rs = &scene->settings;
    printf("plan for %s (%dx%d, %d spp, maxdepth %d, %d buckets over %g-%g nm)\n", path,
           rs->xres, rs->yres, rs->spp, rs->maxdepth, rs->grid.n, rs->grid.lambda_min,
           rs->grid.lambda_max);
    if (plan_write_text(plan, stdout) != 0) {
        fprintf(stderr, "prismfarm plan: cannot write the report\n");
        return finish(&plan, &scene, &desc, 1);
    }
    if (seq_setting)
        printf("\nsequence of %zu frames (the plan above is frame %u's alone): %s\n", fl->n,
               fl->numbers[0], seq_why);
    if (pilot_asked) {
        fflush(stdout);
        if (run_pilot(scene, job.target_error, pilot, &res, &err) < 0) {
            fprintf(stderr, "prismfarm plan: pilot render: %s\n", err.msg);
            return finish(&plan, &scene, &desc, 1);
        }
        print_prediction(scene, &res, job.target_error);
    }
    return finish(&plan, &scene, &desc, rc);
}
