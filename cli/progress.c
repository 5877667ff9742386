#include "progress.h"

#include "predict.h"

#include <math.h>
#include <stdio.h>
#include <unistd.h>

progress_t progress_make(const char *label, int quiet)
{
    return (progress_t){.tty = isatty(STDERR_FILENO),
                        .quiet = quiet,
                        .last_decile = -1,
                        .label = label,
                        .unit = "samples"};
}

void progress_follow_error(progress_t *p, double target, int spp_cap)
{
    p->target = target;
    p->spp_cap = spp_cap;
    p->nrec = 0;
    p->pred_made = 0;
}

void progress_note_error(progress_t *p, int spp, double elapsed, double rel_error)
{
    if (!(p->target > 0.0) || p->nrec >= STOPPING_MAX_RECORDS ||
        (p->nrec > 0 && spp <= p->rec[p->nrec - 1].spp))
        return;
    p->rec[p->nrec++] = (pass_record_t){.pass = p->nrec + 1,
                                        .spp = spp,
                                        .elapsed = elapsed,
                                        .valid = isfinite(rel_error) && rel_error > 0.0,
                                        .rel_error = rel_error};
    if (!p->pred_made) {
        predict_t pr = predict_target(p->rec, p->nrec, p->target);
        if (pr.valid && pr.spp <= p->spp_cap) {
            p->pred_made = 1;
            p->pred_from_spp = spp;
            p->pred_at = elapsed;
            p->pred_spp = predict_pass_spp(&pr, p->spp_cap);
            p->pred_end = predict_pass_seconds(&pr, p->spp_cap);
        }
    }
}

int progress_prediction_line(const progress_t *p, int reached, int spp, double elapsed, char *buf,
                             size_t size)
{
    if (!p->pred_made)
        return 0;
    int n =
        snprintf(buf, size, "prediction after %d spp (%.1f s): error %g at %d spp after %.1f s; ",
                 p->pred_from_spp, p->pred_at, p->target, p->pred_spp, p->pred_end);
    if (n < 0 || (size_t)n >= size)
        return 1;
    if (reached && p->pred_end > 0.0)
        snprintf(buf + n, size - (size_t)n,
                 "reached at %d spp after %.1f s, %.2f x the predicted time", spp, elapsed,
                 elapsed / p->pred_end);
    else
        snprintf(buf + n, size - (size_t)n, "not reached: ended at %d spp after %.1f s", spp,
                 elapsed);
    return 1;
}

/* The error's end time when a target is followed and predicted within the cap, else -1. */
static double error_end(const progress_t *p)
{
    if (!(p->target > 0.0) || p->nrec == 0)
        return -1.0;
    predict_t pr = predict_target(p->rec, p->nrec, p->target);
    if (!pr.valid || pr.spp > p->spp_cap)
        return -1.0;
    return predict_pass_seconds(&pr, p->spp_cap);
}

void progress_update(progress_t *p, uint64_t done, uint64_t total, double elapsed)
{
    if (p->quiet || total == 0)
        return;
    double f = (double)done / (double)total;
    double rate = elapsed > 0 ? (double)done / elapsed : 0;
    double eta = rate > 0 ? (double)(total - done) / rate : 0;
    char extra_buf[160];
    const char *extra = p->extra ? p->extra : "";
    const double end = done < total ? error_end(p) : -1.0;
    if (end > 0.0) {
        /* The target, not the samples, ends this job: time is the measure of the way there. */
        f = fmin(elapsed / end, 0.999);
        eta = fmax(end - elapsed, 0.0);
        snprintf(extra_buf, sizeof extra_buf, "to error %g, predicted%s%s", p->target,
                 *extra ? "; " : "", extra);
        extra = extra_buf;
    }
    if (p->tty) {
        char bar[31];
        int n = (int)(f * 30);
        for (int i = 0; i < 30; i++)
            bar[i] = i < n ? '#' : '.';
        bar[30] = 0;
        fprintf(stderr, "\r[%s] %5.1f%%  %.2f M%s/s  ETA %.0fs %s  ", bar, 100 * f, rate / 1e6,
                p->unit, eta, extra);
        p->open_line = done < total;
        if (done >= total)
            fputc('\n', stderr);
    } else {
        int decile = (int)(f * 10);
        if (decile > p->last_decile || done >= total) {
            p->last_decile = decile;
            fprintf(stderr, "%s: %5.1f%%  %.2f M%s/s  %.1fs elapsed, ETA %.0fs %s\n", p->label,
                    100 * f, rate / 1e6, p->unit, elapsed, eta, extra);
        }
    }
    fflush(stderr);
}

void progress_end(progress_t *p, uint64_t done, uint64_t total, double elapsed, const char *why)
{
    if (p->quiet || total == 0 || done >= total)
        return;
    const char *extra = p->extra ? p->extra : "";
    if (p->tty && p->open_line)
        fputc('\n', stderr);
    fprintf(stderr, "%s: %s after %.1fs: %s (%.1f%% of the samples asked)\n", p->label,
            why ? why : "stopped", elapsed, extra, 100.0 * (double)done / (double)total);
    p->open_line = 0;
    fflush(stderr);
}

void progress_print_master(void *user, const char *message, double elapsed_s)
{
    (void)elapsed_s; /* the master's message says it */
    fprintf(stderr, "prismfarm %s: %s\n", (const char *)user, message);
}
