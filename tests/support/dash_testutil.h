/* dash_testutil: what the tests of the dashboard's request layer share (unit/test_dash_route,
 * fuzz/fuzz_http): a fake master whose reads (dashboard/dash_provider.h) answer from tables the
 * test fills, so that each test states its jobs, passes, tiles, tasks, log and workers as data
 * and keeps only its own actions and preview; and the rule every answer keeps (a status of
 * 200..599 with a content type, every refusal a JSON object with an "error" string). Needs no
 * cmocka (the fuzzer has none). Header-only; each test is its own executable. */
#ifndef PRISMFARM_DASH_TESTUTIL_H
#define PRISMFARM_DASH_TESTUTIL_H

#include "dash_provider.h"
#include "dash_route.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* The tables; a provider's user points at one (or at a struct that begins with one). */
typedef struct testutil_dash_fake {
    const dash_job_t *jobs; /* in id order */
    size_t njobs;
    const dash_pass_t *passes; /* every job's */
    int npasses;
    dash_tilemap_t tiles;    /* every job's but tiles_missing (merged: tiles_merged) */
    const int *tiles_merged; /* tiles.tiles_x * tiles.tiles_y */
    uint64_t tiles_missing;  /* a job whose tiles answer tiles_error */
    const char *tiles_error;
    const dash_task_t *tasks; /* every job's */
    int ntasks;
    /* Log lines: the three after since, numbered up to log_last (0: no bound), their text
     * job_text for a job's log and all_text for the whole log. */
    uint64_t log_last;
    const char *log_job_text, *log_all_text;
    double log_age_s;
    const dash_worker_t *workers;
    size_t nworkers;
} testutil_dash_fake_t;

static inline size_t testutil_dash_jobs(void *user, dash_job_t *out, size_t max)
{
    const testutil_dash_fake_t *f = user;
    size_t n = f->njobs < max ? f->njobs : max;
    memcpy(out, f->jobs, n * sizeof *out);
    return n;
}

static inline int testutil_dash_job(void *user, uint64_t id, dash_job_t *out)
{
    const testutil_dash_fake_t *f = user;
    for (size_t i = 0; i < f->njobs; i++)
        if (f->jobs[i].id == id) {
            *out = f->jobs[i];
            return 0;
        }
    return DASH_ENOENT;
}

static inline int testutil_dash_passes(void *user, uint64_t id, dash_pass_t *out, int max)
{
    (void)id;
    const testutil_dash_fake_t *f = user;
    int n = f->npasses < max ? f->npasses : max;
    memcpy(out, f->passes, (size_t)(n > 0 ? n : 0) * sizeof *out);
    return n;
}

static inline int testutil_dash_tiles(void *user, uint64_t id, dash_tilemap_t *map, err_t *err)
{
    const testutil_dash_fake_t *f = user;
    if (id == f->tiles_missing)
        return err_set(err, "%s", f->tiles_error);
    int *merged = map->merged;
    *map = f->tiles;
    map->merged = merged;
    for (int i = 0; merged && i < f->tiles.tiles_x * f->tiles.tiles_y; i++)
        merged[i] = f->tiles_merged[i];
    return 0;
}

static inline int testutil_dash_tasks(void *user, uint64_t id, dash_task_t *out, int max)
{
    (void)id;
    const testutil_dash_fake_t *f = user;
    int n = f->ntasks < max ? f->ntasks : max;
    memcpy(out, f->tasks, (size_t)(n > 0 ? n : 0) * sizeof *out);
    return n;
}

static inline int testutil_dash_log(void *user, uint64_t job, uint64_t since, dash_log_line_t *out,
                                    int max)
{
    const testutil_dash_fake_t *f = user;
    int n = 0;
    /* s > since: no wrap past UINT64_MAX for a since near it. */
    for (uint64_t s = since + 1; s > since && s <= since + 3 && (!f->log_last || s <= f->log_last) &&
                                 n < max;
         s++)
        out[n++] = (dash_log_line_t){
            .seq = s, .age_s = f->log_age_s, .text = job ? f->log_job_text : f->log_all_text};
    return n;
}

static inline size_t testutil_dash_workers(void *user, dash_worker_t *out, size_t max)
{
    const testutil_dash_fake_t *f = user;
    size_t n = f->nworkers < max ? f->nworkers : max;
    memcpy(out, f->workers, n * sizeof *out);
    return n;
}

/* The reads of a provider over the tables at user; the test adds its actions and preview. */
static inline dash_provider_t testutil_dash_provider(testutil_dash_fake_t *user)
{
    return (dash_provider_t){.user = user,
                             .jobs = testutil_dash_jobs,
                             .job = testutil_dash_job,
                             .passes = testutil_dash_passes,
                             .tiles = testutil_dash_tiles,
                             .tasks = testutil_dash_tasks,
                             .log = testutil_dash_log,
                             .workers = testutil_dash_workers};
}

/* Whether n bytes at p hold needle (memmem is not POSIX). */
static inline bool testutil_holds(const void *p, size_t n, const char *needle)
{
    size_t k = strlen(needle);
    for (size_t i = 0; i + k <= n; i++)
        if (!memcmp((const char *)p + i, needle, k))
            return true;
    return false;
}

/* What is wrong with an answer, or NULL: every answer has a status of 200..599, a content type
 * and its body; every refusal (4xx, 5xx) is a JSON object whose "error" is a string (a plain
 * check of its bytes; the fuzzer parses it too). */
static inline const char *testutil_dash_answer_fault(const dash_response_t *r)
{
    if (r->status < 200 || r->status > 599)
        return "a status outside 200..599";
    if (!r->content_type)
        return "no content type";
    if (r->size && !r->body)
        return "a size without a body";
    if (r->status >= 400 && (strcmp(r->content_type, "application/json") != 0 ||
                             !testutil_holds(r->body, r->size, "\"error\":\"")))
        return "a refusal without a JSON error";
    return NULL;
}

#endif
