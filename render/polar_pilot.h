/* polar_pilot: measures how much ignoring polarisation changes a scene's image, so that the
 * plan carries Stokes vectors where they show and not elsewhere (issue 28, docs/plan.md). A
 * scene that asks for nothing polarised (no sheet, analyser or Stokes output) but whose smooth
 * or rough glass and metal polarise what they reflect and transmit changes its intensities
 * wherever light meets a second Fresnel interface (a gem, glass in glass): the pilot renders a
 * small grid of tiles spread over the image a few samples per pixel with and without
 * polarisation and compares.
 *
 * The figure: per pixel the difference d = Y_polarised - Y_plain of mean luminance, from the
 * same samples (the scalar weights and every random choice are the same both ways, only the
 * carrier's factor differs), twice with disjoint sample ranges A and B; the mean of d_A d_B over
 * the pixels estimates the mean squared systematic change without its noise (A and B are
 * independent, so E[d_A d_B] = E[d]^2), and change = sqrt(max(0, mean d_A d_B)) / mean Y_plain,
 * the normalisation of the job's error estimate (film/error_estimate.h: RMS per-pixel error over
 * the mean luminance). A few samples leave that figure noisy (the jewel's reads 0.96 % at 4 spp,
 * 1.7-2.6 % at 16-64: docs/accuracy.md), so the decision takes its bound two standard errors
 * up -- the mean product plus twice its standard error over the pixels -- and carries
 * polarisation unless the pilot shows the change below the target: a wrong "on" costs
 * 10-50 % more time, a wrong "off" an image off by more than the target.
 *
 * The decision (polar_pilot_decide) is the one rule, made once per job before it starts: by the
 * master for a submitted job, by `prismfarm render` for its own (--direct or its in-process
 * farm), by `prismfarm plan` for its report. It goes to every worker as the job setting
 * `polarized` (proto/job_settings.h), which they obey without measuring, and the journal keeps
 * it, so a restarted master does not decide again. The pilot's figure comes from rendered
 * floats, which another build or CPU may move a little (a sanitizer build read
 * tests/data/render/tiny.pbrt's bound above 1 % where the release build read it below): made
 * once, it cannot make the hosts of one job render it two ways. The target is the job's
 * --target-error, or POLAR_PILOT_TARGET without one or above it: a target error bounds the
 * noise a job accepts, which more samples would lower, while ignoring polarisation is a bias
 * no sample removes, so a loose target does not license one above 1 % (and stopping rules of
 * 1 % or more then never change which samples a job renders: tests/cli/test_cli_accuracy.c).
 *
 * Guarantees: the same figure for the same build on the same CPU (fixed tiles and sample
 * indices, one thread, no clock in it); the scene measured is not changed (the pilot renders a
 * copy of its settings), so a scene shared between threads may be measured. */
#ifndef PRISMFARM_POLAR_PILOT_H
#define PRISMFARM_POLAR_PILOT_H

#include "err.h"
#include "overrides.h"
#include "scene.h"

/* The change above which polarisation is carried when the job has no --target-error: 1 % of
 * the mean luminance, the error a finished render is commonly taken to (docs/plan.md,
 * "Polarisation"). */
#define POLAR_PILOT_TARGET 0.01
/* Samples per pixel of each of the four pilot renders, and the grid of tiles (of
 * POLAR_PILOT_TILE square pixels) spread over the image. */
#define POLAR_PILOT_SPP 4
#define POLAR_PILOT_GRID 8
#define POLAR_PILOT_TILE 4

/* Whether the pilot has anything to measure: polarisation is off, and the scene has a
 * conductor or dielectric (smooth or rough, not a crystal) that polarises. */
int polar_pilot_needed(const scene_t *scene);

/* What one measurement found: the change (as above), its pixels and samples per pixel, and the
 * wall time of the plain and the polarised renders (the same samples: their ratio is what
 * polarised transport costs; not read by any decision). */
typedef struct polar_pilot_result {
    double change;
    double change_hi; /* the change with the mean product 2 standard errors higher */
    int pixels, spp;
    double seconds_plain, seconds_polarised;
} polar_pilot_result_t;

/* Measures the change on a grid x grid of tiles (1..POLAR_PILOT_GRID, tile x tile pixels, the
 * whole image when smaller) at spp samples per pixel per run, whatever the scene's
 * polarisation setting. bench/polar_pilot.c takes it further than the pilot's defaults for
 * docs/accuracy.md. -1 with err when a render failed. */
int polar_pilot_measure(const scene_t *scene, int grid, int tile, int spp,
                        polar_pilot_result_t *out, err_t *err);

/* The plan's decision for one job. setting is the job setting `polarized`: SCENE_POLARIZED_ON
 * where the scene already carries polarisation (a sheet, an analyser, a Stokes output, a
 * polarised light, the file's "bool polarized": cause_file) or where the pilot's bound
 * change_hi exceeds the target; else SCENE_POLARIZED_OFF. */
typedef struct polar_decision {
    int setting;
    int cause_file; /* the scene itself asked for polarisation: no pilot */
    int measured;   /* the pilot ran (a Fresnel interface, nothing asked) */
    polar_pilot_result_t pilot;
    double target; /* the error its bound was compared with */
} polar_decision_t;

/* The decision for scene, whose job has target_error (0: none; the target is
 * min(target_error, POLAR_PILOT_TARGET), POLAR_PILOT_TARGET without one).
 * Runs the pilot when polar_pilot_needed; the scene is not changed. -1 with err when a pilot
 * render failed. */
int polar_pilot_decide(const scene_t *scene, double target_error, polar_decision_t *out,
                       err_t *err);

/* Applies a decision to a scene loaded with the setting left to the file (what loading it with
 * the decision's setting does: polarised on for SCENE_POLARIZED_ON) and records the pilot's
 * figures in scene->settings.polar_pilot for the plan's report. Call before the scene is
 * shared. */
void polar_pilot_record(scene_t *scene, const polar_decision_t *d);

#endif
