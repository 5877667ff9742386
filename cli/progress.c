#include "progress.h"

#include <stdio.h>
#include <unistd.h>

progress_t progress_make(const char *label, int quiet)
{
    return (progress_t){.tty = isatty(STDERR_FILENO), .quiet = quiet, .last_decile = -1, .label = label};
}

void progress_update(progress_t *p, uint64_t done, uint64_t total, double elapsed)
{
    if (p->quiet || total == 0)
        return;
    double f = (double)done / (double)total;
    double rate = elapsed > 0 ? (double)done / elapsed : 0;
    double eta = rate > 0 ? (double)(total - done) / rate : 0;
    const char *extra = p->extra ? p->extra : "";
    if (p->tty) {
        char bar[31];
        int n = (int)(f * 30);
        for (int i = 0; i < 30; i++)
            bar[i] = i < n ? '#' : '.';
        bar[30] = 0;
        fprintf(stderr, "\r[%s] %5.1f%%  %.2f Msamples/s  ETA %.0fs %s  ", bar, 100 * f, rate / 1e6, eta, extra);
        p->open_line = done < total;
        if (done >= total)
            fputc('\n', stderr);
    } else {
        int decile = (int)(f * 10);
        if (decile > p->last_decile || done >= total) {
            p->last_decile = decile;
            fprintf(stderr, "%s: %5.1f%%  %.2f Msamples/s  %.1fs elapsed, ETA %.0fs %s\n", p->label, 100 * f,
                    rate / 1e6, elapsed, eta, extra);
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
