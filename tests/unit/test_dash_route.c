/* dash_route and dash_auth: the dashboard's requests into answers without a socket, over a fake
 * provider -- the routes and their JSON, every bound and malformed input answered 4xx with a
 * message, and who may act: no token, an unknown one, a user on another's job, a job's owner, an
 * administrator (from the admins' folder or --http-token-file), a worker action by a user; who
 * may read (issue 26, finding 3): without a token the count of jobs only, a user the figures, a
 * job's owner and administrators its preview, log and tasks, any token /metrics, everyone
 * everything with public_reads (--dashboard-public). The
 * tokens are real: written by curve_write beside real key pairs, and found through the .pub
 * files' http-token-sha256 lines, as a master finds them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "curve.h"
#include "dash_auth.h"
#include "dash_route.h"
#include "dash_testutil.h"
#include "files_testutil.h"

#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ---------------------------------------------------------------- the fake master */

static dash_job_t fake_job(uint64_t id)
{
    return (dash_job_t){.id = id,
                        .name = id == 1 ? "alice's job" : "orphan",
                        .owner = id == 1 ? "alice" : "",
                        .state = "running",
                        .has_size = id == 1, /* job 2: restored, its scene not loaded yet */
                        .has_tasks = id == 1,
                        .xres = 64,
                        .yres = 48,
                        .spp = 64,
                        .integrator = "path",
                        .samples_done = 64 * 48 * 16,
                        .samples_total = 64 * 48 * 64,
                        .spp_done = 16,
                        .passes_done = 5,
                        .npasses = 7,
                        .has_rel_error = true,
                        .rel_error = 0.05,
                        .elapsed_s = 10,
                        .stop = "",
                        .error = "",
                        .preview_version = id == 1 ? 7 : 0};
}

static const dash_pass_t PASSES[] = {
    {.pass = 1, .spp = 1, .elapsed_s = 0.5, .valid = false, .rel_error = 0.4},
    {.pass = 2, .spp = 2, .elapsed_s = 1.5, .valid = true, .rel_error = 0.2},
    {.pass = 3, .spp = 4, .elapsed_s = 2.5, .valid = true, .rel_error = 0.4 / 3},
};

static const int MERGED[] = {0, 1, 2, 3};

static const dash_task_t TASKS[] = {{.task = 9,
                                     .tile = 1,
                                     .pass = 2,
                                     .sample_begin = 2,
                                     .sample_end = 4,
                                     .attempt = 1,
                                     .worker = 3,
                                     .worker_name = "host:1",
                                     .running_s = 1.5}};

static const dash_worker_t WORKERS[] = {{.id = 3,
                                         .name = "host:1",
                                         .key = "",
                                         .threads = 4,
                                         .state = "busy",
                                         .tasks_running = 1,
                                         .tasks_done = 10,
                                         .samples_done = 1000,
                                         .has_rate = true,
                                         .samples_per_s = 250}};

/* The reads answer from the tables (dash_testutil.h); the actions count here. */
typedef struct fake {
    testutil_dash_fake_t reads; /* first: the provider's user is the fake */
    dash_job_t jobs[2];
    int cancels, pauses, resumes, priority, requeued_task, blocks, unblocks;
    char last_actor[80];
    bool actor_admin;
} fake_t;

static void fake_init(fake_t *f)
{
    for (int i = 0; i < 2; i++)
        f->jobs[i] = fake_job((uint64_t)i + 1);
    f->reads = (testutil_dash_fake_t){
        .jobs = f->jobs,
        .njobs = 2,
        .passes = PASSES,
        .npasses = 3,
        .tiles = {.xres = 64, .yres = 48, .tile = 32, .tiles_x = 2, .tiles_y = 2, .npasses = 7},
        .tiles_merged = MERGED,
        .tiles_missing = 2,
        .tiles_error = "not loaded",
        .tasks = TASKS,
        .ntasks = 1,
        .log_last = 3,
        .log_job_text = "job line",
        .log_all_text = "line",
        .log_age_s = 1,
        .workers = WORKERS,
        .nworkers = 1};
}

static int f_preview(void *user, uint64_t id, uint8_t **png, size_t *size, err_t *err)
{
    (void)user, (void)err;
    if (id != 1)
        return DASH_ENOENT;
    *png = malloc(8);
    memcpy(*png, "\x89PNG\r\n\x1a\n", 8);
    *size = 8;
    return 0;
}

static int f_metrics(void *user, char **text, size_t *len, err_t *err)
{
    (void)user, (void)err;
    *text = strdup("# TYPE prismfarm_queue_depth gauge\nprismfarm_queue_depth 3\n");
    *len = strlen(*text);
    return 0;
}

static void note(fake_t *f, const dash_identity_t *who)
{
    snprintf(f->last_actor, sizeof f->last_actor, "%s", who->name);
    f->actor_admin = who->admin;
}

static int f_cancel(void *user, const dash_identity_t *who, uint64_t job, err_t *err)
{
    (void)job, (void)err;
    fake_t *f = user;
    note(f, who);
    f->cancels++;
    return 0;
}

static int f_set_priority(void *user, const dash_identity_t *who, uint64_t job, int p, err_t *err)
{
    (void)job, (void)err;
    fake_t *f = user;
    note(f, who);
    f->priority = p;
    return 0;
}

static int f_requeue(void *user, const dash_identity_t *who, uint64_t job, uint32_t task,
                     err_t *err)
{
    (void)job;
    fake_t *f = user;
    note(f, who);
    if (task != 9)
        return err_set(err, "task %u is not running", task);
    f->requeued_task = (int)task;
    return 0;
}

static int f_blocklist(void *user, const dash_identity_t *who, uint64_t worker, bool block,
                       err_t *err)
{
    fake_t *f = user;
    note(f, who);
    if (worker != 3) {
        err_set(err, "no worker %llu", (unsigned long long)worker);
        return DASH_ENOENT;
    }
    if (block)
        f->blocks++;
    else
        f->unblocks++;
    return 0;
}

/* ---------------------------------------------------------------- fixture */

typedef struct fixture {
    fake_t fake;
    dash_provider_t p;
    dash_auth_t *auth;
    dash_router_t *router;
    char alice[CURVE_TOKEN_CHARS + 1], bob[CURVE_TOKEN_CHARS + 1], root[CURVE_TOKEN_CHARS + 1],
        ops[CURVE_TOKEN_CHARS + 1], worker[CURVE_TOKEN_CHARS + 1], scrape[CURVE_TOKEN_CHARS + 1];
    char auth_alice[100], auth_bob[100], auth_root[100], auth_ops[100], auth_worker[100],
        auth_scrape[100];
} fixture_t;

/* A key pair and token for name in dir; its token goes to token. */
static void make_key(const char *dir, const char *name, char token[CURVE_TOKEN_CHARS + 1])
{
    curve_pair_t pair;
    curve_paths_t paths;
    err_t err;
    mkdir(dir, 0700);
    assert_int_equal(curve_generate(&pair, &err), 0);
    assert_int_equal(curve_token_generate(token), 0);
    assert_int_equal(curve_write(&pair, token, dir, name, false, &paths, &err), 0);
}

static int setup(void **state)
{
    if (testutil_scratch_setup(state) < 0)
        return -1;
    fixture_t *f = calloc(1, sizeof *f);
    char clients[600], admins[600], workers[600], tokfile[700], scrapefile[700];
    snprintf(clients, sizeof clients, "%s", testutil_scratch("clients"));
    snprintf(admins, sizeof admins, "%s", testutil_scratch("admins"));
    snprintf(workers, sizeof workers, "%s", testutil_scratch("workers"));
    make_key(clients, "alice", f->alice);
    make_key(clients, "bob", f->bob);
    make_key(admins, "root", f->root);
    make_key(workers, "w1", f->worker);
    make_key(testutil_scratch("keys"), "ops", f->ops);
    snprintf(tokfile, sizeof tokfile, "%s/ops.token", testutil_scratch("keys"));
    make_key(testutil_scratch("keys"), "prom", f->scrape);
    snprintf(scrapefile, sizeof scrapefile, "%s/prom.token", testutil_scratch("keys"));
    snprintf(f->auth_scrape, sizeof f->auth_scrape, "Bearer %s", f->scrape);
    snprintf(f->auth_alice, sizeof f->auth_alice, "Bearer %s", f->alice);
    snprintf(f->auth_bob, sizeof f->auth_bob, "Bearer %s", f->bob);
    snprintf(f->auth_root, sizeof f->auth_root, "Bearer %s", f->root);
    snprintf(f->auth_ops, sizeof f->auth_ops, "Bearer %s", f->ops);
    snprintf(f->auth_worker, sizeof f->auth_worker, "Bearer %s", f->worker);
    fake_init(&f->fake);
    f->p = testutil_dash_provider(&f->fake.reads);
    f->p.preview = f_preview;
    f->p.cancel = f_cancel;
    f->p.set_priority = f_set_priority;
    f->p.requeue = f_requeue;
    f->p.blocklist = f_blocklist;
    f->p.metrics = f_metrics;
    err_t err;
    dash_auth_config_t ac = {.clients_dir = clients,
                             .admins_dir = admins,
                             .token_file = tokfile,
                             .metrics_token_file = scrapefile};
    f->auth = dash_auth_new(&ac, &err);
    assert_non_null(f->auth);
    dash_router_config_t rc = {.check_host = true};
    f->router = dash_router_new(&f->p, f->auth, &rc, &err);
    assert_non_null(f->router);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture_t *f = *state;
    dash_router_destroy(&f->router);
    dash_auth_destroy(&f->auth);
    free(f);
    return testutil_scratch_teardown(state);
}

/* One request; the JSON answer parsed into *json when asked (NULL when not JSON). */
static int ask(fixture_t *f, const char *method, const char *path, const char *auth,
               const char *body, json_t **json)
{
    dash_request_t req = {.method = method,
                          .path = path,
                          .host = "127.0.0.1:8080",
                          .authorization = auth,
                          .body = body,
                          .body_len = body ? strlen(body) : 0};
    dash_response_t r;
    dash_route(f->router, &req, &r);
    if (json) {
        json_error_t jerr;
        *json = strcmp(r.content_type, "application/json")
                    ? NULL
                    : json_loadb((const char *)r.body, r.size, 0, &jerr);
    }
    int status = r.status;
    /* Every refusal says why. */
    const char *fault = testutil_dash_answer_fault(&r);
    if (fault)
        fail_msg("%s %s answered %d: %s", method, path, status, fault);
    dash_response_free(&r);
    return status;
}

/* ---------------------------------------------------------------- reads */

static void test_pages_and_reads(void **state)
{
    fixture_t *f = *state;
    dash_request_t req = {.method = "GET", .path = "/"};
    dash_response_t r;
    dash_route(f->router, &req, &r);
    assert_int_equal(r.status, 200);
    assert_string_equal(r.content_type, "text/html; charset=utf-8");
    assert_true(testutil_holds(r.body, r.size, "/app.js"));
    dash_response_free(&r);
    assert_int_equal(ask(f, "GET", "/app.js", NULL, NULL, NULL), 200);
    assert_int_equal(ask(f, "GET", "/style.css", NULL, NULL, NULL), 200);
    assert_int_equal(ask(f, "GET", "/nothing.js", NULL, NULL, NULL), 404);

    json_t *j;
    assert_int_equal(ask(f, "GET", "/api/jobs", f->auth_alice, NULL, &j), 200);
    json_t *jobs = json_object_get(j, "jobs");
    assert_int_equal(json_array_size(jobs), 2);
    json_t *one = json_array_get(jobs, 0);
    assert_string_equal(json_string_value(json_object_get(one, "owner")), "alice");
    /* progress 1/4 after 10 s: 30 s to go. */
    assert_true(fabs(json_real_value(json_object_get(one, "progress")) - 0.25) < 1e-12);
    assert_true(fabs(json_real_value(json_object_get(one, "eta_s")) - 30.0) < 1e-9);
    /* What the master cannot do is said, so the page greys it. */
    json_t *actions = json_object_get(j, "actions");
    assert_true(json_is_true(json_object_get(actions, "cancel")));
    assert_true(json_is_false(json_object_get(actions, "pause")));
    assert_true(json_is_true(json_object_get(actions, "tokens")));
    /* A field the master does not have is absent, not invented. */
    assert_null(json_object_get(one, "priority"));
    assert_int_equal(json_integer_value(json_object_get(one, "xres")), 64);
    assert_int_equal(json_integer_value(json_object_get(one, "tasks_total")), 0);
    /* Issue 25: a restored job's unknown size and tasks are absent, never 0 x 0 or 0 of 0. */
    json_t *two = json_array_get(jobs, 1);
    assert_null(json_object_get(two, "xres"));
    assert_null(json_object_get(two, "spp"));
    assert_null(json_object_get(two, "npasses"));
    assert_null(json_object_get(two, "tasks_total"));
    json_decref(j);
    /* A paused job has no ETA: it is not running. */
    f->fake.jobs[0].state = "paused";
    assert_int_equal(ask(f, "GET", "/api/jobs/1", f->auth_alice, NULL, &j), 200);
    assert_null(json_object_get(j, "eta_s"));
    assert_string_equal(json_string_value(json_object_get(j, "state")), "paused");
    json_decref(j);
    f->fake.jobs[0].state = "running";

    assert_int_equal(ask(f, "GET", "/api/jobs/1", f->auth_alice, NULL, &j), 200);
    json_t *passes = json_object_get(j, "passes");
    assert_int_equal(json_array_size(passes), 3);
    assert_null(json_object_get(json_array_get(passes, 0), "rel_error")); /* no estimate yet */
    assert_true(json_is_real(json_object_get(json_array_get(passes, 1), "rel_error")));
    json_decref(j);

    assert_int_equal(ask(f, "GET", "/api/jobs/1/tiles", f->auth_alice, NULL, &j), 200);
    assert_int_equal(json_array_size(json_object_get(j, "merged")), 4);
    assert_int_equal(json_integer_value(json_array_get(json_object_get(j, "merged"), 3)), 3);
    assert_int_equal(json_array_size(json_object_get(j, "running")), 1);
    json_decref(j);
    assert_int_equal(ask(f, "GET", "/api/jobs/2/tiles", f->auth_alice, NULL, NULL), 409);

    assert_int_equal(ask(f, "GET", "/api/jobs/1/tasks", f->auth_alice, NULL, &j), 200);
    json_t *t = json_array_get(json_object_get(j, "tasks"), 0);
    assert_string_equal(json_string_value(json_object_get(t, "worker_name")), "host:1");
    assert_string_equal(json_string_value(json_object_get(t, "kind")), "camera");
    json_decref(j);

    assert_int_equal(ask(f, "GET", "/api/workers", f->auth_alice, NULL, &j), 200);
    assert_int_equal(json_integer_value(json_object_get(
                         json_array_get(json_object_get(j, "workers"), 0), "samples_done")),
                     1000);
    /* The worker's rate as the master computes it (`prismfarm workers`). */
    assert_true(fabs(json_real_value(json_object_get(
                         json_array_get(json_object_get(j, "workers"), 0), "samples_per_s")) -
                     250) < 1e-12);
    json_decref(j);

    dash_request_t png = {
        .method = "GET", .path = "/api/jobs/1/preview.png", .authorization = f->auth_alice};
    dash_route(f->router, &png, &r);
    assert_int_equal(r.status, 200);
    assert_string_equal(r.content_type, "image/png");
    assert_int_equal(r.size, 8);
    dash_response_free(&r);
    /* Job 2 has no preview yet, job 3 does not exist. */
    assert_int_equal(ask(f, "GET", "/api/jobs/2/preview.png", f->auth_root, NULL, NULL), 404);
    assert_int_equal(ask(f, "GET", "/api/jobs/3", f->auth_alice, NULL, NULL), 404);
    assert_int_equal(ask(f, "GET", "/api/jobs/", f->auth_alice, NULL, NULL),
                     200); /* trailing slash */
}

static void test_log_since(void **state)
{
    fixture_t *f = *state;
    dash_arg_t since = {"since", "1"};
    dash_request_t req = {.method = "GET",
                          .path = "/api/jobs/1/log",
                          .args = &since,
                          .nargs = 1,
                          .authorization = f->auth_alice};
    dash_response_t r;
    dash_route(f->router, &req, &r);
    assert_int_equal(r.status, 200);
    json_error_t jerr;
    json_t *j = json_loadb((const char *)r.body, r.size, 0, &jerr);
    json_t *lines = json_object_get(j, "lines");
    assert_int_equal(json_array_size(lines), 2); /* 2 and 3 */
    assert_int_equal(json_integer_value(json_object_get(json_array_get(lines, 0), "seq")), 2);
    json_decref(j);
    dash_response_free(&r);
    const char *bad[] = {"-1", "x", "1e3", "", "123456789012345678901234"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        since.value = bad[i];
        dash_route(f->router, &req, &r);
        assert_int_equal(r.status, 400);
        dash_response_free(&r);
    }
}

/* Who reads what (docs/security.md, "The dashboard's HTTP port"). */
static void test_reads_follow_owners(void **state)
{
    fixture_t *f = *state;
    json_t *j;
    /* Nobody: how many jobs by state, no name nor owner, and how to sign in. */
    dash_request_t req = {.method = "GET", .path = "/api/jobs"};
    dash_response_t r;
    dash_route(f->router, &req, &r);
    assert_int_equal(r.status, 200);
    assert_false(testutil_holds(r.body, r.size, "alice"));
    assert_false(testutil_holds(r.body, r.size, "orphan"));
    assert_true(testutil_holds(r.body, r.size, "\"counts\":{\"running\":2}"));
    assert_true(testutil_holds(r.body, r.size, "NAME.token"));
    dash_response_free(&r);
    const char *closed[] = {"/api/jobs/1",       "/api/jobs/1/preview.png",
                            "/api/jobs/1/log",   "/api/jobs/1/tasks",
                            "/api/jobs/1/tiles", "/api/workers",
                            "/api/log",          "/metrics"};
    for (size_t i = 0; i < sizeof closed / sizeof *closed; i++) {
        if (ask(f, "GET", closed[i], NULL, NULL, NULL) != 401)
            fail_msg("%s without a token: not 401", closed[i]);
        /* A worker's key is not a user of the dashboard either. */
        if (ask(f, "GET", closed[i], f->auth_worker, NULL, NULL) != 401)
            fail_msg("%s with a worker's token: not 401", closed[i]);
    }
    /* bob: the figures and the workers, not alice's pixels, log or tasks. */
    assert_int_equal(ask(f, "GET", "/api/jobs", f->auth_bob, NULL, &j), 200);
    json_t *one = json_array_get(json_object_get(j, "jobs"), 0);
    assert_string_equal(json_string_value(json_object_get(one, "owner")), "alice");
    assert_true(json_is_false(json_object_get(one, "can_read")));
    assert_true(json_is_false(json_object_get(one, "can_act")));
    json_decref(j);
    assert_int_equal(ask(f, "GET", "/api/jobs/1", f->auth_bob, NULL, NULL), 200);
    assert_int_equal(ask(f, "GET", "/api/jobs/1/tiles", f->auth_bob, NULL, NULL), 200);
    assert_int_equal(ask(f, "GET", "/api/workers", f->auth_bob, NULL, NULL), 200);
    const char *own[] = {"/api/jobs/1/preview.png", "/api/jobs/1/log", "/api/jobs/1/tasks"};
    for (size_t i = 0; i < sizeof own / sizeof *own; i++) {
        assert_int_equal(ask(f, "GET", own[i], f->auth_bob, NULL, &j), 403);
        assert_non_null(strstr(json_string_value(json_object_get(j, "error")), "'alice'"));
        json_decref(j);
        assert_int_equal(ask(f, "GET", own[i], f->auth_alice, NULL, NULL), 200);
        assert_int_equal(ask(f, "GET", own[i], f->auth_root, NULL, NULL), 200);
        assert_int_equal(ask(f, "GET", own[i], f->auth_ops, NULL, NULL), 200);
    }
    assert_int_equal(ask(f, "GET", "/api/jobs", f->auth_alice, NULL, &j), 200);
    one = json_array_get(json_object_get(j, "jobs"), 0);
    assert_true(json_is_true(json_object_get(one, "can_read")));
    assert_true(json_is_true(json_object_get(one, "can_act")));
    json_decref(j);
    /* A job without an owner is an administrator's; so is the whole log. */
    assert_int_equal(ask(f, "GET", "/api/jobs/2/log", f->auth_alice, NULL, NULL), 403);
    assert_int_equal(ask(f, "GET", "/api/jobs/2/log", f->auth_root, NULL, NULL), 200);
    assert_int_equal(ask(f, "GET", "/api/log", f->auth_alice, NULL, NULL), 403);
    assert_int_equal(ask(f, "GET", "/api/log", f->auth_root, NULL, NULL), 200);
    /* A token that is not accepted says so, rather than showing less. */
    assert_int_equal(ask(f, "GET", "/api/jobs", "Bearer 1234", NULL, NULL), 401);

    /* /metrics: any token, the scrapers' too; theirs reads nothing else and acts on nothing. */
    req = (dash_request_t){.method = "GET", .path = "/metrics", .authorization = f->auth_scrape};
    dash_route(f->router, &req, &r);
    assert_int_equal(r.status, 200);
    assert_string_equal(r.content_type, "text/plain; version=0.0.4; charset=utf-8");
    assert_true(testutil_holds(r.body, r.size, "prismfarm_queue_depth 3"));
    dash_response_free(&r);
    assert_int_equal(ask(f, "GET", "/metrics", f->auth_bob, NULL, NULL), 200);
    assert_int_equal(ask(f, "GET", "/api/jobs/1", f->auth_scrape, NULL, NULL), 403);
    assert_int_equal(ask(f, "GET", "/api/jobs/1/log", f->auth_scrape, NULL, NULL), 403);
    assert_int_equal(ask(f, "GET", "/api/workers", f->auth_scrape, NULL, NULL), 403);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", f->auth_scrape, NULL, NULL), 403);
    assert_int_equal(ask(f, "POST", "/api/workers/3/blocklist", f->auth_scrape, NULL, NULL), 403);
    assert_int_equal(f->fake.cancels + f->fake.blocks, 0);
    assert_int_equal(ask(f, "GET", "/api/whoami", f->auth_scrape, NULL, &j), 200);
    assert_true(json_is_true(json_object_get(j, "scraper")));
    json_decref(j);
}

/* --dashboard-public: every read open, and said; actions as before. */
static void test_public_reads(void **state)
{
    fixture_t *f = *state;
    err_t err;
    dash_router_config_t rc = {.check_host = true, .public_reads = true};
    dash_router_t *open = dash_router_new(&f->p, f->auth, &rc, &err);
    assert_non_null(open);
    dash_router_t *keep = f->router;
    f->router = open;
    json_t *j;
    assert_int_equal(ask(f, "GET", "/api/jobs", NULL, NULL, &j), 200);
    assert_int_equal(json_array_size(json_object_get(j, "jobs")), 2);
    assert_true(json_is_true(json_object_get(json_object_get(j, "actions"), "public_reads")));
    json_decref(j);
    const char *paths[] = {"/api/jobs/1/preview.png",
                           "/api/jobs/1/log",
                           "/api/jobs/1/tasks",
                           "/api/jobs/2/log",
                           "/api/workers",
                           "/api/log",
                           "/metrics"};
    for (size_t i = 0; i < sizeof paths / sizeof *paths; i++)
        if (ask(f, "GET", paths[i], NULL, NULL, NULL) != 200)
            fail_msg("%s on a public dashboard: not 200", paths[i]);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", NULL, NULL, NULL), 401);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", f->auth_bob, NULL, NULL), 403);
    f->router = keep;
    dash_router_destroy(&open);
}

/* ---------------------------------------------------------------- malformed input */

static void test_malformed(void **state)
{
    fixture_t *f = *state;
    assert_int_equal(ask(f, "GET", "/api/jobs/abc", NULL, NULL, NULL), 400);
    assert_int_equal(ask(f, "GET", "/api/jobs/-1", NULL, NULL, NULL), 400);
    assert_int_equal(ask(f, "GET", "/api/jobs/18446744073709551616", NULL, NULL, NULL), 400);
    assert_int_equal(ask(f, "GET", "/api/jobs/18446744073709551615", f->auth_alice, NULL, NULL),
                     404);
    assert_int_equal(ask(f, "GET", "/api//jobs", NULL, NULL, NULL), 404);
    assert_int_equal(ask(f, "GET", "api/jobs", NULL, NULL, NULL), 404);
    assert_int_equal(ask(f, "GET", "/api/a/b/c/d/e/f/g/h/i", NULL, NULL, NULL), 404);
    assert_int_equal(ask(f, "GET", "/../../etc/passwd", NULL, NULL, NULL), 404);
    assert_int_equal(ask(f, "DELETE", "/api/jobs/1", NULL, NULL, NULL), 405);
    assert_int_equal(ask(f, "POST", "/index.html", NULL, NULL, NULL), 405);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/explode", f->auth_root, NULL, NULL), 404);

    char longpath[DASH_MAX_PATH + 10];
    memset(longpath, 'a', sizeof longpath - 1);
    longpath[0] = '/';
    longpath[sizeof longpath - 1] = 0;
    assert_int_equal(ask(f, "GET", longpath, NULL, NULL, NULL), 414);

    char big[DASH_MAX_BODY + 2];
    memset(big, ' ', sizeof big - 1);
    big[sizeof big - 1] = 0;
    assert_int_equal(ask(f, "POST", "/api/jobs/1/priority", f->auth_root, big, NULL), 413);

    char longarg[DASH_MAX_ARG + 2];
    memset(longarg, '1', sizeof longarg - 1);
    longarg[sizeof longarg - 1] = 0;
    dash_arg_t a = {"since", longarg};
    dash_request_t req = {.method = "GET", .path = "/api/log", .args = &a, .nargs = 1};
    dash_response_t r;
    dash_route(f->router, &req, &r);
    assert_int_equal(r.status, 400);
    dash_response_free(&r);

    /* Another origin's name for 127.0.0.1 (DNS rebinding) is refused; ours are not. */
    const char *hosts[] = {"evil.example", "127.0.0.1.evil", "localhost:80a", "127.0.0.1:123456"};
    for (size_t i = 0; i < sizeof hosts / sizeof *hosts; i++) {
        req = (dash_request_t){.method = "GET", .path = "/api/jobs", .host = hosts[i]};
        dash_route(f->router, &req, &r);
        assert_int_equal(r.status, 421);
        dash_response_free(&r);
    }
    const char *ours[] = {"localhost", "127.0.0.1:1", "[::1]:8080", "localhost:65535"};
    for (size_t i = 0; i < sizeof ours / sizeof *ours; i++) {
        req = (dash_request_t){.method = "GET", .path = "/api/jobs", .host = ours[i]};
        dash_route(f->router, &req, &r);
        assert_int_equal(r.status, 200);
        dash_response_free(&r);
    }
}

/* ---------------------------------------------------------------- actions */

static void test_actions_need_a_token(void **state)
{
    fixture_t *f = *state;
    dash_request_t req = {.method = "POST", .path = "/api/jobs/1/cancel"};
    dash_response_t r;
    dash_route(f->router, &req, &r);
    assert_int_equal(r.status, 401);
    assert_true(r.www_authenticate);
    dash_response_free(&r);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", "Basic YWxpY2U6eA==", NULL, NULL), 401);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", "Bearer short", NULL, NULL), 401);
    char forged[100];
    snprintf(forged, sizeof forged, "Bearer %s", f->alice);
    forged[10] = forged[10] == 'a' ? 'b' : 'a';
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", forged, NULL, NULL), 401);
    /* A worker's key has a token too, but workers are not users of the dashboard. */
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", f->auth_worker, NULL, NULL), 401);
    assert_int_equal(f->fake.cancels, 0);

    json_t *j;
    assert_int_equal(ask(f, "GET", "/api/whoami", f->auth_alice, NULL, &j), 200);
    assert_string_equal(json_string_value(json_object_get(j, "name")), "alice");
    assert_true(json_is_false(json_object_get(j, "admin")));
    json_decref(j);
    assert_int_equal(ask(f, "GET", "/api/whoami", f->auth_ops, NULL, &j), 200);
    assert_string_equal(json_string_value(json_object_get(j, "name")), "ops");
    assert_true(json_is_true(json_object_get(j, "admin")));
    json_decref(j);
    assert_int_equal(ask(f, "GET", "/api/whoami", NULL, NULL, NULL), 401);
}

static void test_who_may_act(void **state)
{
    fixture_t *f = *state;
    /* bob on alice's job: refused; alice on hers: done; nobody but an admin on a job without
     * an owner. */
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", f->auth_bob, NULL, NULL), 403);
    assert_int_equal(f->fake.cancels, 0);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/cancel", f->auth_alice, NULL, NULL), 200);
    assert_int_equal(f->fake.cancels, 1);
    assert_string_equal(f->fake.last_actor, "alice");
    assert_false(f->fake.actor_admin);
    assert_int_equal(ask(f, "POST", "/api/jobs/2/cancel", f->auth_alice, NULL, NULL), 403);
    assert_int_equal(ask(f, "POST", "/api/jobs/2/cancel", f->auth_root, NULL, NULL), 200);
    assert_true(f->fake.actor_admin);
    assert_int_equal(ask(f, "POST", "/api/jobs/2/cancel", f->auth_ops, NULL, NULL), 200);
    assert_string_equal(f->fake.last_actor, "ops");
    assert_int_equal(f->fake.cancels, 3);
    assert_int_equal(ask(f, "POST", "/api/jobs/3/cancel", f->auth_root, NULL, NULL), 404);

    /* Workers: administrators only. */
    assert_int_equal(ask(f, "POST", "/api/workers/3/blocklist", f->auth_alice, NULL, NULL), 403);
    assert_int_equal(ask(f, "POST", "/api/workers/3/blocklist", f->auth_root, NULL, NULL), 200);
    assert_int_equal(ask(f, "POST", "/api/workers/3/unblock", f->auth_root, NULL, NULL), 200);
    assert_int_equal(ask(f, "POST", "/api/workers/4/unblock", f->auth_root, NULL, NULL), 404);
    assert_int_equal(ask(f, "POST", "/api/workers/x/unblock", f->auth_root, NULL, NULL), 400);
    assert_int_equal(f->fake.blocks, 1);
    assert_int_equal(f->fake.unblocks, 1);

    /* Requeue: a task of the job, by its owner. */
    assert_int_equal(ask(f, "POST", "/api/jobs/1/tasks/9/requeue", f->auth_alice, NULL, NULL), 200);
    assert_int_equal(f->fake.requeued_task, 9);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/tasks/8/requeue", f->auth_alice, NULL, NULL), 409);
    assert_int_equal(
        ask(f, "POST", "/api/jobs/1/tasks/4294967296/requeue", f->auth_alice, NULL, NULL), 404);
}

static void test_priority_body(void **state)
{
    fixture_t *f = *state;
    const char *path = "/api/jobs/1/priority";
    assert_int_equal(ask(f, "POST", path, f->auth_alice, "{\"priority\": 5}", NULL), 200);
    assert_int_equal(f->fake.priority, 5);
    assert_int_equal(ask(f, "POST", path, f->auth_alice, "{\"priority\": -1000}", NULL), 200);
    assert_int_equal(f->fake.priority, -1000);
    const char *bad[] = {"",
                         "{",
                         "[]",
                         "{\"priority\": \"5\"}",
                         "{\"priority\": 1.5}",
                         "{\"priority\": 1001}",
                         "{\"priority\": 99999999999999999999}",
                         "{\"priority\": 1, \"priority\": 2}",
                         "{\"other\": 1}"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        assert_int_equal(ask(f, "POST", path, f->auth_alice, bad[i], NULL), 400);
    assert_int_equal(f->fake.priority, -1000);
    /* NUL bytes inside a body. */
    dash_request_t req = {.method = "POST",
                          .path = path,
                          .authorization = f->auth_alice,
                          .body = "{\"priority\"\0: 3}",
                          .body_len = 16};
    dash_response_t r;
    dash_route(f->router, &req, &r);
    assert_int_equal(r.status, 400);
    dash_response_free(&r);
}

static void test_missing_operation_is_501(void **state)
{
    fixture_t *f = *state;
    /* The fake has no pause: a clear 501, whoever asks. */
    json_t *j;
    assert_int_equal(ask(f, "POST", "/api/jobs/1/pause", f->auth_alice, NULL, &j), 501);
    assert_non_null(strstr(json_string_value(json_object_get(j, "error")), "pause"));
    json_decref(j);
    assert_int_equal(ask(f, "POST", "/api/jobs/1/resume", NULL, NULL, NULL), 501);
    assert_int_equal(f->fake.pauses, 0);
}

/* No folder and no token file: nothing can act, and it says why. */
static void test_no_tokens(void **state)
{
    fixture_t *f = *state;
    err_t err;
    dash_auth_config_t none = {0};
    dash_auth_t *auth = dash_auth_new(&none, &err);
    assert_non_null(auth);
    assert_false(dash_auth_any(auth));
    dash_router_t *r = dash_router_new(&f->p, auth, NULL, &err);
    dash_request_t req = {
        .method = "POST", .path = "/api/jobs/1/cancel", .authorization = f->auth_root};
    dash_response_t out;
    dash_route(r, &req, &out);
    assert_int_equal(out.status, 401);
    assert_true(testutil_holds(out.body, out.size, "--http-token-file"));
    dash_response_free(&out);
    dash_router_destroy(&r);
    dash_auth_destroy(&auth);
    assert_int_equal(f->fake.cancels, 0);
}

/* ---------------------------------------------------------------- token files */

static void test_token_files(void **state)
{
    (void)state;
    err_t err;
    uint8_t hash[CURVE_TOKEN_HASH];
    char tok[CURVE_TOKEN_CHARS + 1], pub[CURVE_Z85 + 1];
    /* A token others may read is refused, like a secret key. */
    const char *p = testutil_scratch("open.token");
    assert_int_equal(curve_token_generate(tok), 0);
    testutil_write_text(p, tok, 0644);
    assert_int_equal(curve_load_token(p, hash, &err), -1);
    assert_non_null(strstr(err.msg, "chmod 600"));
    chmod(p, 0600);
    assert_int_equal(curve_load_token(p, hash, &err), 0);
    testutil_write_text(p, "# only a comment\nnot-hex\n", 0600);
    assert_int_equal(curve_load_token(p, hash, &err), -1);

    /* A .pub written before tokens existed stays valid; one with a malformed hash line is
     * refused with its line. */
    const char *old = testutil_scratch("old.pub");
    testutil_write_text(old,
                        "# old\npublic-key = "
                        "Yne@$w-vo<fVvi]a<NY6T1ed:M$fCG*[IaLV{hID\n",
                        0644);
    bool has = true;
    assert_int_equal(curve_load_public_token(old, pub, hash, &has, &err), 0);
    assert_false(has);
    const char *bad = testutil_scratch("bad.pub");
    testutil_write_text(bad,
                        "public-key = Yne@$w-vo<fVvi]a<NY6T1ed:M$fCG*[IaLV{hID\n"
                        "http-token-sha256 = 12ab\n",
                        0644);
    assert_int_equal(curve_load_public(bad, pub, &err), -1);
    assert_non_null(strstr(err.msg, ":2:"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_pages_and_reads, setup, teardown),
        cmocka_unit_test_setup_teardown(test_log_since, setup, teardown),
        cmocka_unit_test_setup_teardown(test_malformed, setup, teardown),
        cmocka_unit_test_setup_teardown(test_reads_follow_owners, setup, teardown),
        cmocka_unit_test_setup_teardown(test_public_reads, setup, teardown),
        cmocka_unit_test_setup_teardown(test_actions_need_a_token, setup, teardown),
        cmocka_unit_test_setup_teardown(test_who_may_act, setup, teardown),
        cmocka_unit_test_setup_teardown(test_priority_body, setup, teardown),
        cmocka_unit_test_setup_teardown(test_missing_operation_is_501, setup, teardown),
        cmocka_unit_test_setup_teardown(test_no_tokens, setup, teardown),
        cmocka_unit_test_setup_teardown(test_token_files, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
