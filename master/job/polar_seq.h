/* polar_seq: one polarisation decision for a whole frame sequence (issue 28). Decided frame by
 * frame (render/polar_pilot.h), an animation whose frames sit near the pilot's threshold -- or
 * whose polariser leaves some frames -- renders some frames polarised and others not, and
 * flickers between the two. A sequence is therefore decided once, and every frame renders with
 * that decision:
 *
 *   - on when any frame's scene asks for polarisation itself (a polariser or retarder sheet,
 *     the camera's analyser, a polarised light, a Stokes output, the file's "bool polarized"):
 *     a structural reason, read from every frame's loaded scene at no cost;
 *   - else on when the pilot's bound (change_hi) exceeds the target on any of the frames it
 *     measures: the worst change, since a wrong "off" leaves a bias no sample removes while a
 *     wrong "on" costs time only (polar_pilot.h). The pilot measures at most POLAR_SEQ_PILOTS
 *     frames, spread evenly from the first to the last (both included): an animation's frames
 *     change gradually (a camera path, a turning object), so the spread sees the range of
 *     views, and the cost stays that of a few jobs' pilots however long the sequence is (each
 *     frame's own pilot would cost one per frame);
 *   - else off.
 *
 * The same rule and the same frames serve the master (master/loop/submit.c: frames measured on
 * the load threads as they load), `prismfarm render` of a sequence (--direct, or frames of
 * several folders) and `prismfarm plan` of one, so they agree. The decision goes into every
 * frame's settings (`polarized`), which the journal keeps, so a restarted master resumes the
 * frames with it and decides nothing again. Pure: no clock, no threads; the same frames give the
 * same decision (the pilot's own figure is deterministic on one build and CPU). */
#ifndef PRISMFARM_POLAR_SEQ_H
#define PRISMFARM_POLAR_SEQ_H

#include "polar_pilot.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* The most frames of a sequence the pilot measures. */
#define POLAR_SEQ_PILOTS 5

/* Whether the pilot measures frame k (0-based) of a sequence of n: the frames
 * round(i (n - 1) / (POLAR_SEQ_PILOTS - 1)), i = 0..POLAR_SEQ_PILOTS - 1 -- every frame when n is
 * POLAR_SEQ_PILOTS or fewer, else the first, the last and three evenly between. */
bool polar_seq_pilots(size_t k, size_t n);

/* One frame's part in the decision: whether its scene asks for polarisation (cause_file), and,
 * when pilot is true and the scene has a polarising interface to measure, the pilot's figure
 * against target_error (as polar_pilot_decide: setting is then what the frame alone would
 * decide). The scene is not changed. -1 with err when a pilot render failed. */
int polar_seq_frame(const scene_t *scene, bool pilot, double target_error, polar_decision_t *out,
                    err_t *err);

/* The sequence's decision, built from its frames' parts in any order. */
typedef struct polar_seq {
    int setting;                /* SCENE_POLARIZED_ON or _OFF: every frame's */
    size_t nframes;             /* frames added */
    long cause_frame;           /* the lowest frame index whose scene asks for it; -1: none */
    size_t measured;            /* frames the pilot measured */
    long worst_frame;           /* the measured frame with the highest bound; -1: none measured */
    polar_pilot_result_t worst; /* its figures */
    double target;              /* the error the bounds were compared with */
} polar_seq_t;

/* An empty decision (off, nothing added) for a sequence whose job has target_error. */
polar_seq_t polar_seq_make(double target_error);
/* Adds frame k's part (polar_seq_frame) and updates the decision. Adding the same parts in
 * another order gives the same decision and figures (ties go to the lower index). */
void polar_seq_add(polar_seq_t *s, size_t k, const polar_decision_t *frame);
/* One line saying the decision and why, naming frames by numbers[k] (NULL: k + 1), e.g.
 * "polarisation on for all 3 frames: frame 2's scene asks for it (a polariser, an analyser, a
 * polarised light or a Stokes output)". */
void polar_seq_why(const polar_seq_t *s, const uint32_t *numbers, char *buf, size_t size);

#endif
