/* progress: the progress display of long commands: a bar with percent, rate and ETA redrawn in
 * place on a terminal, or a plain line every 10 % when the output is not a terminal. */
#ifndef PRISMFARM_PROGRESS_H
#define PRISMFARM_PROGRESS_H

#include <stdint.h>

typedef struct progress {
    int tty, quiet;
    int last_decile;
    int open_line; /* a bar is drawn without its newline */
    const char *label; /* prefix of plain lines, e.g. "render" */
    const char *extra; /* optional text after the rate, e.g. "3 workers" */
} progress_t;

progress_t progress_make(const char *label, int quiet);
/* done of total units (samples) after elapsed seconds. */
void progress_update(progress_t *p, uint64_t done, uint64_t total, double elapsed);
/* The end of a run that stopped short of its total (a target error or time limit reached):
 * the last line, with why, so a bar is never left open. Harmless after a complete run. */
void progress_end(progress_t *p, uint64_t done, uint64_t total, double elapsed, const char *why);

/* A client_rpc_progress_fn (client_rpc.h) printing the master's PROGRESS messages as
 * "prismfarm LABEL: MESSAGE" on stderr; user is the label (a const char *). */
void progress_print_master(void *user, const char *message, double elapsed_s);

#endif
