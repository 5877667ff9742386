/* fuzz_http: libFuzzer harness for the dashboard's request layer (dashboard/dash_route.h), what
 * the master's HTTP port hands it from any peer after libmicrohttpd has parsed the request
 * line and headers. An input is a request in lines:
 *     METHOD \n PATH \n HOST \n AUTHORIZATION \n QUERY \n BODY...
 * (HOST or AUTHORIZATION "-": absent; QUERY "k=v&k2&..."; the body is the rest, NUL bytes
 * allowed). The provider is a fake with jobs (one owned by "alice", one by nobody), a worker,
 * tasks, log lines and every action; the tokens are real: alice's in a clients folder, an
 * administrator's token file, both with fixed values the seeds use. Beyond "no crash, no leak",
 * it checks every answer has a status of 200..599 and a content type, that every 4xx/5xx is a
 * JSON object with an "error" string, and that no action was carried out for a request without
 * a token the master accepts. */
#define _XOPEN_SOURCE 700

#include "curve.h"
#include "dash_auth.h"
#include "dash_route.h"
#include "dash_testutil.h"
#include "fuzz_fixture.h"

#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* The seeds' tokens (tests/fuzz/corpus/fuzz_http): alice is a user, ops an administrator. */
#define ALICE_TOKEN "a11ce000000000000000000000000000000000000000000000000000000000a1"
#define OPS_TOKEN "0b5000000000000000000000000000000000000000000000000000000000000f"
/* The public key of ZeroMQ RFC 26's example server: any valid Z85 key does. */
#define SOME_KEY "Yne@$w-vo<fVvi]a<NY6T1ed:M$fCG*[IaLV{hID"

static char g_base[4096];
static dash_auth_t *g_auth;
static int g_actions; /* actions carried out by the current input */
static dash_job_t g_jobs[3]; /* the fake master's, from job_of */
static dash_job_t job_of(uint64_t id);

static void cleanup(void)
{
    dash_auth_destroy(&g_auth);
    if (g_base[0])
        fuzz_fixture_remove(g_base);
}

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void write_text(const char *dir, const char *name, const char *text, mode_t mode)
{
    char path[8400];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (fuzz_fixture_write(path, text, strlen(text)) != 0 || chmod(path, mode) != 0)
        abort();
}

static void hex_hash(const char *token, char out[65])
{
    uint8_t h[CURVE_TOKEN_HASH];
    curve_token_hash(token, strlen(token), h);
    for (int i = 0; i < CURVE_TOKEN_HASH; i++)
        snprintf(out + 2 * i, 3, "%02x", h[i]);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    for (int i = 0; i < 3; i++)
        g_jobs[i] = job_of((uint64_t)i + 1);
    if (fuzz_fixture_make("fuzz-http", 0, g_base, sizeof g_base) != 0)
        abort();
    atexit(cleanup);
    char clients[4200], hash[65], text[400];
    snprintf(clients, sizeof clients, "%s/clients", g_base);
    if (mkdir(clients, 0700) != 0)
        abort();
    hex_hash(ALICE_TOKEN, hash);
    snprintf(text, sizeof text, "public-key = %s\nhttp-token-sha256 = %s\n", SOME_KEY, hash);
    write_text(clients, "alice.pub", text, 0644);
    write_text(g_base, "ops.token", OPS_TOKEN "\n", 0600);
    char token_file[4200];
    snprintf(token_file, sizeof token_file, "%s/ops.token", g_base);
    err_t err;
    dash_auth_config_t ac = {.clients_dir = clients, .token_file = token_file};
    if (!(g_auth = dash_auth_new(&ac, &err))) {
        fprintf(stderr, "fuzz_http: %s\n", err.msg);
        abort();
    }
    return 0;
}

/* ---------------------------------------------------------------- the fake master */

static dash_job_t job_of(uint64_t id)
{
    return (dash_job_t){.id = id,
                        .name = "job",
                        .owner = id == 1 ? "alice" : "",
                        .state = id == 3 ? "done" : "running",
                        .xres = 16,
                        .yres = 16,
                        .spp = 4,
                        .integrator = "path",
                        .samples_done = 256,
                        .samples_total = 1024,
                        .spp_done = 1,
                        .passes_done = 1,
                        .npasses = 3,
                        .elapsed_s = 1,
                        .stop = "",
                        .error = "",
                        .preview_version = id,
                        .photons = id == 2,
                        .photon_batches = 4,
                        .photon_batches_done = 1};
}

static const dash_pass_t PASSES[] = {
    {.pass = 1, .spp = 1, .elapsed_s = 0, .valid = false, .rel_error = 0.1},
    {.pass = 2, .spp = 2, .elapsed_s = 1, .valid = true, .rel_error = 0.1},
};

static const int MERGED[] = {0, 1, 2, 0};

static const dash_task_t TASKS[] = {
    {.task = 1, .tile = 1, .sample_end = 1, .attempt = 1, .worker = 7, .worker_name = "w",
     .running_s = 0.5},
    {.task = 0x80000000u, .photon = true, .tile = -1, .pass = -1, .attempt = 2, .worker = 7,
     .worker_name = "w"},
};

static const dash_worker_t WORKERS[] = {
    {.id = 7, .name = "w", .key = "", .threads = 2, .state = "idle", .has_blocklisted = true}};

/* The reads answer from tables (dash_testutil.h): jobs 1 (alice's), 2 (nobody's, with photons)
 * and 3 (done, its tiles forgotten). */
static testutil_dash_fake_t g_reads = {.jobs = g_jobs,
                                       .njobs = 3,
                                       .passes = PASSES,
                                       .npasses = 2,
                                       .tiles = {.xres = 16,
                                                 .yres = 16,
                                                 .tile = 8,
                                                 .tiles_x = 2,
                                                 .tiles_y = 2,
                                                 .npasses = 3},
                                       .tiles_merged = MERGED,
                                       .tiles_missing = 3,
                                       .tiles_error = "forgotten",
                                       .tasks = TASKS,
                                       .ntasks = 2,
                                       .log_job_text = "line",
                                       .log_all_text = "line",
                                       .workers = WORKERS,
                                       .nworkers = 1};

static int f_preview(void *u, uint64_t id, uint8_t **png, size_t *size, err_t *err)
{
    (void)u;
    if (id == 2)
        return err_set(err, "cannot read the preview");
    if (!(*png = malloc(4)))
        return err_set(err, "out of memory");
    memcpy(*png, "\x89PNG", 4);
    *size = 4;
    return 0;
}

static int f_cancel(void *u, const dash_identity_t *who, uint64_t job, err_t *err)
{
    (void)u, (void)who;
    g_actions++;
    return job == 3 ? err_set(err, "job 3 is done already") : 0;
}

static int f_pause(void *u, const dash_identity_t *who, uint64_t job, bool pause, err_t *err)
{
    (void)u, (void)who, (void)job, (void)pause, (void)err;
    g_actions++;
    return 0;
}

static int f_priority(void *u, const dash_identity_t *who, uint64_t job, int p, err_t *err)
{
    (void)u, (void)who, (void)job, (void)err;
    g_actions++;
    if (p < -DASH_PRIORITY_MAX || p > DASH_PRIORITY_MAX)
        abort(); /* the router bounds it */
    return 0;
}

static int f_requeue(void *u, const dash_identity_t *who, uint64_t job, uint32_t task, err_t *err)
{
    (void)u, (void)who, (void)job;
    g_actions++;
    return task == 1 ? 0 : err_set(err, "task %u is not running", task);
}

static int f_block(void *u, const dash_identity_t *who, uint64_t worker, bool block, err_t *err)
{
    (void)u, (void)block;
    g_actions++;
    if (!who->admin)
        abort(); /* the router lets only administrators through */
    if (worker != 7) {
        err_set(err, "no worker");
        return DASH_ENOENT;
    }
    return 0;
}

/* ---------------------------------------------------------------- one input */

/* The next line of [*p, end) as a NUL-terminated copy (malloc'ed); the rest after it. */
static char *take_line(const uint8_t **p, const uint8_t *end)
{
    const uint8_t *nl = memchr(*p, '\n', (size_t)(end - *p));
    size_t n = nl ? (size_t)(nl - *p) : (size_t)(end - *p);
    char *s = malloc(n + 1);
    if (!s)
        abort();
    memcpy(s, *p, n);
    s[n] = 0;
    *p += n + (nl ? 1 : 0);
    return s;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const uint8_t *p = data, *end = data + size;
    char *method = take_line(&p, end), *path = take_line(&p, end), *host = take_line(&p, end),
         *auth = take_line(&p, end), *query = take_line(&p, end);
    dash_arg_t args[16];
    size_t nargs = 0;
    for (char *save = NULL, *kv = strtok_r(query, "&", &save); kv && nargs < 16;
         kv = strtok_r(NULL, "&", &save)) {
        char *eq = strchr(kv, '=');
        if (eq)
            *eq = 0;
        args[nargs++] = (dash_arg_t){.key = kv, .value = eq ? eq + 1 : NULL};
    }
    dash_provider_t prov = testutil_dash_provider(&g_reads);
    prov.preview = f_preview;
    prov.cancel = f_cancel;
    prov.pause = f_pause;
    prov.set_priority = f_priority;
    prov.requeue = f_requeue;
    prov.blocklist = f_block;
    err_t err;
    dash_router_config_t rc = {.check_host = size % 2 == 0};
    dash_router_t *router = dash_router_new(&prov, g_auth, &rc, &err);
    if (!router)
        abort();
    dash_request_t req = {.method = method,
                          .path = path,
                          .host = strcmp(host, "-") ? host : NULL,
                          .authorization = strcmp(auth, "-") ? auth : NULL,
                          .args = args,
                          .nargs = nargs,
                          .body = (const char *)p,
                          .body_len = (size_t)(end - p)};
    g_actions = 0;
    dash_response_t out;
    dash_route(router, &req, &out);
    const char *fault = testutil_dash_answer_fault(&out);
    if (fault) {
        fprintf(stderr, "fuzz_http: an answer with status %d: %s\n", out.status, fault);
        abort();
    }
    if (out.status >= 400) {
        json_error_t jerr;
        json_t *j = json_loadb((const char *)out.body, out.size, 0, &jerr);
        if (!json_is_string(json_object_get(j, "error"))) {
            fprintf(stderr, "fuzz_http: a %d without a JSON error: %.*s\n", out.status,
                    (int)out.size, (const char *)out.body);
            abort();
        }
        json_decref(j);
    }
    if (getenv("FUZZ_HTTP_VERBOSE"))
        fprintf(stderr, "fuzz_http: %s %s -> %d %.*s\n", method, path, out.status,
                out.size < 160 && strcmp(out.content_type, "image/png") ? (int)out.size : 0,
                (const char *)out.body);
    /* No action without a token that the master accepts. */
    dash_identity_t who;
    if (g_actions > 0 && dash_auth_identify(g_auth, req.authorization, &who, &err) < 0) {
        fprintf(stderr, "fuzz_http: an action carried out for an unknown token\n");
        abort();
    }
    dash_response_free(&out);
    dash_router_destroy(&router);
    free(method);
    free(path);
    free(host);
    free(auth);
    free(query);
    return 0;
}
