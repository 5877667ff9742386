/* journal_ack: what copying the WAL into journal.db at each acknowledged submission costs
 * (issue 26, finding 6; docs/reliability.md, "A deleted WAL"). A journal in a scratch folder
 * takes N submissions, each after R result rows (the results a busy farm journals between two
 * submissions, with B-byte blobs in segment files), once with journal_checkpoint_wal after each
 * submission and once without; it prints the seconds per submission of each and of the
 * checkpoint alone. Measures; asserts nothing. usage: bench_journal_ack [N] [R] [B] */
#include "journal.h"

#include "clock.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int run(const char *dir, int n, int r, size_t b, int checkpoint, double *per_job,
               double *per_ckpt)
{
    err_t err;
    journal_t *j = journal_open(dir, &err);
    if (!j) {
        fprintf(stderr, "%s\n", err.msg);
        return -1;
    }
    unsigned char *blob = calloc(1, b);
    double total = 0;
    for (int k = 0; k < n; k++) {
        for (int i = 0; i < r; i++)
            if (journal_add_result(j, 1, 0, (uint32_t)(k * r + i), 0, i, k, blob, b, &err) < 0) {
                fprintf(stderr, "%s\n", err.msg);
                return -1;
            }
        journal_job_t rec = {.id = (uint64_t)k + 2, .name = "bench", .hash = "0", .main = "m"};
        double t0 = clock_now_s();
        if (journal_add_job(j, &rec, &err) < 0 || (checkpoint && journal_checkpoint_wal(j, &err) < 0)) {
            fprintf(stderr, "%s\n", err.msg);
            return -1;
        }
        total += clock_now_s() - t0;
    }
    journal_stats_t s = journal_stats(j);
    *per_job = total / n;
    *per_ckpt = s.checkpoints ? s.checkpoint_seconds / (double)s.checkpoints : 0;
    journal_close(&j);
    free(blob);
    return 0;
}

int main(int argc, char **argv)
{
    int n = argc > 1 ? atoi(argv[1]) : 200;
    int r = argc > 2 ? atoi(argv[2]) : 100;
    size_t b = argc > 3 ? (size_t)atol(argv[3]) : 4096;
    char tmpl[2][64] = {"/tmp/bench-journal-ack-XXXXXX", "/tmp/bench-journal-ack-XXXXXX"};
    double job[2], ckpt[2];
    for (int c = 0; c < 2; c++) {
        if (!mkdtemp(tmpl[c]) || run(tmpl[c], n, r, b, c, &job[c], &ckpt[c]) < 0)
            return 1;
        char cmd[160];
        snprintf(cmd, sizeof cmd, "rm -rf %s", tmpl[c]);
        if (system(cmd) != 0)
            fprintf(stderr, "cannot remove %s\n", tmpl[c]);
    }
    printf("| submissions | results between | blob bytes | ms per submission, no checkpoint | "
           "ms per submission, checkpoint | ms per checkpoint |\n|---|---|---|---|---|---|\n");
    printf("| %d | %d | %zu | %.3f | %.3f | %.3f |\n", n, r, b, job[0] * 1e3, job[1] * 1e3,
           ckpt[1] * 1e3);
    return 0;
}
