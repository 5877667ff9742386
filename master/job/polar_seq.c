#include "polar_seq.h"

#include <math.h>
#include <stdio.h>

/* The target polar_pilot_decide compares with (polar_pilot.h): the job's target error, capped
 * at POLAR_PILOT_TARGET, which also stands in without one. */
static double seq_target(double target_error)
{
    return target_error > 0.0 ? fmin(target_error, POLAR_PILOT_TARGET) : POLAR_PILOT_TARGET;
}

bool polar_seq_pilots(size_t k, size_t n)
{
    if (k >= n)
        return false;
    if (n <= POLAR_SEQ_PILOTS)
        return true;
    const size_t d = POLAR_SEQ_PILOTS - 1;
    for (size_t i = 0; i <= d; i++)
        if ((i * (n - 1) + d / 2) / d == k)
            return true;
    return false;
}

int polar_seq_frame(const scene_t *scene, bool pilot, double target_error, polar_decision_t *out,
                    err_t *err)
{
    if (pilot)
        return polar_pilot_decide(scene, target_error, out, err);
    *out = (polar_decision_t){.setting = SCENE_POLARIZED_OFF, .target = seq_target(target_error)};
    if (scene->settings.polarised) {
        out->setting = SCENE_POLARIZED_ON;
        out->cause_file = 1;
    }
    return 0;
}

polar_seq_t polar_seq_make(double target_error)
{
    return (polar_seq_t){.setting = SCENE_POLARIZED_OFF,
                         .cause_frame = -1,
                         .worst_frame = -1,
                         .target = seq_target(target_error)};
}

void polar_seq_add(polar_seq_t *s, size_t k, const polar_decision_t *f)
{
    s->nframes++;
    if (f->cause_file && (s->cause_frame < 0 || (long)k < s->cause_frame))
        s->cause_frame = (long)k;
    if (f->measured) {
        s->measured++;
        if (s->worst_frame < 0 || f->pilot.change_hi > s->worst.change_hi ||
            (f->pilot.change_hi == s->worst.change_hi && (long)k < s->worst_frame)) {
            s->worst_frame = (long)k;
            s->worst = f->pilot;
        }
    }
    s->setting = s->cause_frame >= 0 || (s->worst_frame >= 0 && s->worst.change_hi > s->target)
                     ? SCENE_POLARIZED_ON
                     : SCENE_POLARIZED_OFF;
}

void polar_seq_why(const polar_seq_t *s, const uint32_t *numbers, char *buf, size_t size)
{
    const char *on = s->setting == SCENE_POLARIZED_ON ? "on" : "off";
#define FRAME(k) ((unsigned)(numbers ? numbers[k] : (uint32_t)(k) + 1u))
    if (s->cause_frame >= 0)
        snprintf(buf, size,
                 "polarisation %s for all %zu frames: frame %u's scene asks for it (a polariser "
                 "or retarder sheet, an analyser, a polarised light, a Stokes output or \"bool "
                 "polarized\")",
                 on, s->nframes, FRAME(s->cause_frame));
    else if (s->worst_frame >= 0)
        snprintf(buf, size,
                 "polarisation %s for all %zu frames: the pilot measured %zu of them, the most on "
                 "frame %u: ignoring it changes the image by %.2f %% (up to %.2f %%), %s the "
                 "target error of %g %%",
                 on, s->nframes, s->measured, FRAME(s->worst_frame), 100.0 * s->worst.change,
                 100.0 * s->worst.change_hi, s->setting == SCENE_POLARIZED_ON ? "above" : "within",
                 100.0 * s->target);
    else
        snprintf(buf, size,
                 "polarisation %s for all %zu frames: no frame asks for it and none has glass or "
                 "metal that polarises",
                 on, s->nframes);
#undef FRAME
}
