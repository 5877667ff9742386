/* progress: the progress display of long commands: a bar with percent, rate and ETA redrawn in
 * place on a terminal, or a plain line every 10 % when the output is not a terminal. */
#ifndef PRISMFARM_PROGRESS_H
#define PRISMFARM_PROGRESS_H

#include "stopping.h"

#include <stddef.h>
#include <stdint.h>

typedef struct progress {
    int tty, quiet;
    int last_decile;
    int open_line;     /* a bar is drawn without its newline */
    const char *label; /* prefix of plain lines, e.g. "render" */
    const char *extra; /* optional text after the rate, e.g. "3 workers" */
    const char *unit;  /* what done and total count, plural: "samples" (progress_make's) */
    /* A job with a target error (progress_follow_error): the error estimates seen so far. */
    double target;
    int spp_cap;
    pass_record_t rec[STOPPING_MAX_RECORDS];
    int nrec;
    /* The first prediction within the cap, kept for the summary (progress_prediction_line). */
    int pred_made, pred_from_spp, pred_spp;
    double pred_at, pred_end;
} progress_t;

progress_t progress_make(const char *label, int quiet);

/* A job that ends at a target error: from the first error estimate on, the percentage and the
 * ETA follow the error instead of the samples -- the time film/predict.h predicts for the
 * target from the estimates noted so far (rounded to the job's whole passes, at most spp_cap
 * spp), said as such ("ETA 12s to error 0.05, predicted"). When the prediction needs more than
 * spp_cap, the cap comes first and the samples rule as without a target. */
void progress_follow_error(progress_t *p, double target, int spp_cap);

/* An error estimate: rel_error after spp samples per pixel, elapsed seconds on the clock that
 * progress_update is given. Ignored unless spp grew since the last one. */
void progress_note_error(progress_t *p, int spp, double elapsed, double rel_error);
/* After the job: how close the first prediction came, one line without a newline, e.g.
 * "prediction after 4 spp (1.2 s): error 0.05 at 64 spp after 9.8 s; reached at 64 spp after
 * 11.0 s, 1.12 x the predicted time" (reached: the job ended at the target; otherwise it says
 * where it ended instead). Returns 0 and leaves buf alone when no prediction was made (no
 * target, no estimate, or every prediction beyond the spp cap). */
int progress_prediction_line(const progress_t *p, int reached, int spp, double elapsed, char *buf,
                             size_t size);

/* done of total units (samples, or the unit set) after elapsed seconds. */
void progress_update(progress_t *p, uint64_t done, uint64_t total, double elapsed);
/* The end of a run that stopped short of its total (a target error or time limit reached):
 * the last line, with why, so a bar is never left open. Harmless after a complete run. */
void progress_end(progress_t *p, uint64_t done, uint64_t total, double elapsed, const char *why);

/* A client_rpc_progress_fn (client_rpc.h) printing the master's PROGRESS messages as
 * "prismfarm LABEL: MESSAGE" on stderr; user is the label (a const char *). */
void progress_print_master(void *user, const char *message, double elapsed_s);

#endif
