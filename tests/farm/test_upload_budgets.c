/* Small uploads that decode into large things (issue 26, finding 2), sent straight to a master
 * process as SUBMIT messages (no client parses them first), each refused by a budget before it
 * is built, with a message naming the file and the master's option, and the master's peak
 * resident memory (VmHWM in /proc/PID/status) under the bar:
 *  - a 1.2 MB .ply.gz whose header claims 10^8 vertices and one face: refused from the header
 *    (--max-vertices), nothing of its 1.2 GB body inflated; peak RSS under 1 GB;
 *  - a 4 MB gzip bomb of 4 GiB of spaces, Included: refused while it is counted, at the text
 *    budget, never inflated; peak RSS under 256 MB;
 *  - a 4 MB file Included 400 times (1.6 GB of text): refused by the text budget
 *    (--max-text-mb), and a second client's submission sent meanwhile is taken.
 * Outside the sanitizer build the master also runs under an address-space limit (RLIMIT_AS),
 * so that a master without these budgets fails for lack of memory rather than taking the
 * machine's (the sanitizer reserves terabytes of address space, so there VmHWM alone holds).
 * Deadlines are the generous ones of test_wait.h; nothing here times the machine. */
#define _GNU_SOURCE /* prlimit */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "bundle.h"
#include "clock.h"
#include "farm_testutil.h"
#include "net.h"
#include "proto.h"
#include "test_wait.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <zlib.h>
#include <zmq.h>

#if defined(__SANITIZE_ADDRESS__)
#define UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define UNDER_ASAN 1
#endif
#endif
#ifndef UNDER_ASAN
#define UNDER_ASAN 0
#endif

#define MB ((size_t)1 << 20)

typedef struct bytes {
    uint8_t *data;
    size_t len, cap;
} bytes_t;

static void bytes_add(bytes_t *b, const void *data, size_t n)
{
    if (b->len + n > b->cap) {
        b->cap = 2 * (b->len + n);
        b->data = realloc(b->data, b->cap);
        assert_non_null(b->data);
    }
    memcpy(b->data + b->len, data, n);
    b->len += n;
}

/* data[0..n) as one gzip member (RFC 1952 allows members to follow one another). */
static bytes_t gzip_member(const void *data, size_t n)
{
    z_stream z;
    memset(&z, 0, sizeof z);
    assert_int_equal(deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY), Z_OK);
    bytes_t out = {.cap = deflateBound(&z, (uLong)n) + 64};
    out.data = malloc(out.cap);
    assert_non_null(out.data);
    z.next_in = (unsigned char *)(uintptr_t)data;
    z.avail_in = (uInt)n;
    z.next_out = out.data;
    z.avail_out = (uInt)out.cap;
    assert_int_equal(deflate(&z, Z_FINISH), Z_STREAM_END);
    out.len = out.cap - z.avail_out;
    deflateEnd(&z);
    return out;
}

/* `times` members each inflating to n bytes of `fill`. */
static void add_filled(bytes_t *b, int fill, size_t n, size_t times)
{
    uint8_t *chunk = malloc(n);
    assert_non_null(chunk);
    memset(chunk, fill, n);
    bytes_t m = gzip_member(chunk, n);
    free(chunk);
    for (size_t i = 0; i < times; i++)
        bytes_add(b, m.data, m.len);
    free(m.data);
}

static void add_text_member(bytes_t *b, const char *text)
{
    bytes_t m = gzip_member(text, strlen(text));
    bytes_add(b, m.data, m.len);
    free(m.data);
}

static const char SCENE_HEAD[] =
    "Film \"rgb\" \"integer xresolution\" [ 8 ] \"integer yresolution\" [ 8 ]\n"
    "WorldBegin\nLightSource \"point\" \"rgb I\" [ 1 1 1 ]\n";

/* A master on loopback with plain text (--insecure: the test speaks the protocol itself),
 * under an address-space limit of as_mb MiB outside the sanitizer build (0: none). */
static pid_t start_master(const char *name, char *cep, size_t as_mb)
{
    char spool[600], log[600], wep[256];
    snprintf(spool, sizeof spool, "%s/%s-spool", testutil_scratch_dir(), name);
    snprintf(log, sizeof log, "%s/%s.log", testutil_scratch_dir(), name);
    pid_t pid = testutil_spawn(log, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                               "tcp://127.0.0.1:*", "--spool", spool, "--insecure", NULL);
    const char *cap = getenv("PRISMFARM_BOMB_AS_MB"); /* bench/upload_bombs.sh: another cap */
    if (cap)
        as_mb = (size_t)strtoull(cap, NULL, 10);
    if (as_mb && !UNDER_ASAN) {
        struct rlimit rl = {.rlim_cur = (rlim_t)as_mb * MB, .rlim_max = (rlim_t)as_mb * MB};
        if (prlimit(pid, RLIMIT_AS, &rl, NULL) != 0)
            fail_msg("prlimit: %s", strerror(errno));
    }
    testutil_read_endpoints(spool, wep, cep, log);
    return pid;
}

/* The master's peak resident memory, in bytes (VmHWM). */
static size_t peak_rss(pid_t pid)
{
    char path[64], line[256];
    snprintf(path, sizeof path, "/proc/%ld/status", (long)pid);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    size_t kb = 0;
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, "VmHWM:", 6))
            kb = strtoull(line + 6, NULL, 10);
    fclose(f);
    assert_true(kb > 0);
    return kb * 1024;
}

typedef struct client {
    void *ctx;
    net_t *net;
} client_t;

/* Sends SUBMIT of a bundle of files (path, bytes) whose main is files[0], on a new connection. */
static client_t submit(const char *cep, const proto_bundle_file_t *files, size_t nfiles)
{
    client_t c = {.ctx = zmq_ctx_new()};
    assert_non_null(c.ctx);
    err_t err;
    if (!(c.net = net_new(c.ctx, NET_DEALER, NULL, &err)) || net_connect(c.net, cep, &err))
        fail_msg("connect %s: %s", cep, err.msg);
    proto_msg_t req = {
        .type = PROTO_SUBMIT,
        .submit = {.name = files[0].path,
                   .settings = {.spp = 1, .seed = -1},
                   .bundle = {.main = files[0].path, .files = files, .nfiles = nfiles}}};
    if (net_send(c.net, NULL, &req, &err))
        fail_msg("send SUBMIT: %s", err.msg);
    return c;
}

/* The answer to the SUBMIT (PROGRESS and HEARTBEAT skipped), within the test's deadline. */
static void answer(client_t *c, proto_msg_t *m)
{
    double end = clock_now_s() + test_wait_s();
    while (clock_now_s() < end) {
        err_t err;
        int r = net_recv(c->net, NULL, m, 100, &err);
        if (r == PROTO_EAGAIN)
            continue;
        if (r)
            fail_msg("recv: %s", err.msg);
        if (m->type != PROTO_HEARTBEAT && m->type != PROTO_PROGRESS)
            return;
        proto_msg_free(m);
    }
    fail_msg("no answer to SUBMIT within %.0f s", test_wait_s());
}

static void client_close(client_t *c)
{
    net_destroy(&c->net);
    zmq_ctx_term(c->ctx);
}

/* The refusal of a submission, whose message must hold each of the NULL-terminated needles;
 * the master's peak RSS and the time to the answer are printed first (bench/upload_bombs.sh
 * reads them, also from a master without the budgets), and the peak returned. */
static size_t expect_refused(pid_t master, const char *cep, const proto_bundle_file_t *files,
                             size_t n, ...)
{
    double t0 = clock_now_s();
    client_t c = submit(cep, files, n);
    proto_msg_t m;
    answer(&c, &m);
    size_t peak = peak_rss(master);
    print_message("answered in %.2f s, master peak RSS %.1f MB: %s\n", clock_now_s() - t0,
                  peak / 1e6, m.type == PROTO_ERROR ? m.error.message : proto_type_name(m.type));
    if (m.type != PROTO_ERROR)
        fail_msg("the submission was answered %s, not refused", proto_type_name(m.type));
    va_list ap;
    va_start(ap, n);
    for (const char *s = va_arg(ap, const char *); s; s = va_arg(ap, const char *))
        if (!strstr(m.error.message, s))
            fail_msg("the refusal \"%s\" does not say \"%s\"", m.error.message, s);
    va_end(ap);
    proto_msg_free(&m);
    client_close(&c);
    return peak;
}

/* (a) The vertex bomb: 10^8 vertices of three floats (1.2 GB of zeros in 1200 members of
 * 10^6 bytes) and one face, about 1.2 MB compressed. */
static void test_vertex_bomb(void **state)
{
    (void)state;
    bytes_t ply = {0};
    add_text_member(&ply, "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\n"
                          "property float x\nproperty float y\nproperty float z\n"
                          "element face 1\nproperty list uchar int vertex_indices\nend_header\n");
    add_filled(&ply, 0, 1000000, 1200);
    const uint8_t face[13] = {3, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0};
    bytes_t f = gzip_member(face, sizeof face);
    bytes_add(&ply, f.data, f.len);
    free(f.data);
    print_message("the .ply.gz: %zu bytes\n", ply.len);
    char main_text[512];
    snprintf(main_text, sizeof main_text,
             "%sShape \"plymesh\" \"string filename\" [ \"bomb.ply.gz\" ]\n", SCENE_HEAD);
    proto_bundle_file_t files[] = {
        {.path = "main.pbrt", .data = (const uint8_t *)main_text, .size = strlen(main_text)},
        {.path = "bomb.ply.gz", .data = ply.data, .size = ply.len}};
    char cep[256];
    pid_t master = start_master("vertex", cep, 2048);
    size_t peak = expect_refused(master, cep, files, 2, "bomb.ply.gz", "100000000 vertices",
                                 "--max-vertices", NULL);
    assert_true(peak < (size_t)1000 * 1000 * 1000);
    testutil_stop(master, SIGTERM);
    free(ply.data);
}

/* (b) The gzip bomb: 4 GiB of spaces in 4096 members of 1 MiB, about 4 MB compressed. */
static void test_gzip_bomb(void **state)
{
    (void)state;
    bytes_t gz = {0};
    add_filled(&gz, ' ', MB, 4096);
    print_message("the .pbrt.gz: %zu bytes\n", gz.len);
    char main_text[512];
    snprintf(main_text, sizeof main_text, "%sInclude \"bomb.pbrt.gz\"\n", SCENE_HEAD);
    proto_bundle_file_t files[] = {
        {.path = "main.pbrt", .data = (const uint8_t *)main_text, .size = strlen(main_text)},
        {.path = "bomb.pbrt.gz", .data = gz.data, .size = gz.len}};
    char cep[256];
    pid_t master = start_master("gzip", cep, 2048);
    size_t peak =
        expect_refused(master, cep, files, 2, "bomb.pbrt.gz", "inflates to more than", NULL);
    assert_true(peak < (size_t)256 * 1000 * 1000);
    testutil_stop(master, SIGTERM);
    free(gz.data);
}

/* (c) 400 Includes of a 4 MB file of comments, and a small scene from another client sent
 * while the master reads them: the first is refused at the text budget, the second taken. */
static void test_include_bomb(void **state)
{
    (void)state;
    size_t part_len = 4 * MB;
    char *part = malloc(part_len);
    assert_non_null(part);
    static const char line[] = "# padding padding padding padding padding padding padding\n";
    for (size_t i = 0; i < part_len; i++)
        part[i] = line[i % (sizeof line - 1)];
    part[part_len - 1] = '\n';
    size_t main_cap = sizeof SCENE_HEAD + 400 * 32;
    char *main_text = malloc(main_cap);
    assert_non_null(main_text);
    size_t n = (size_t)snprintf(main_text, main_cap, "%s", SCENE_HEAD);
    for (int i = 0; i < 400; i++)
        n += (size_t)snprintf(main_text + n, main_cap - n, "Include \"part.pbrt\"\n");
    proto_bundle_file_t files[] = {
        {.path = "main.pbrt", .data = (const uint8_t *)main_text, .size = n},
        {.path = "part.pbrt", .data = (const uint8_t *)part, .size = part_len}};
    char small[512];
    snprintf(small, sizeof small, "%sShape \"sphere\"\n", SCENE_HEAD);
    proto_bundle_file_t honest[] = {
        {.path = "small.pbrt", .data = (const uint8_t *)small, .size = strlen(small)}};
    char cep[256];
    pid_t master = start_master("include", cep, 2048);
    double t0 = clock_now_s();
    client_t bomb = submit(cep, files, 2);
    client_t other = submit(cep, honest, 1);
    proto_msg_t m;
    answer(&bomb, &m);
    print_message("answered in %.2f s, master peak RSS %.1f MB: %s\n", clock_now_s() - t0,
                  peak_rss(master) / 1e6,
                  m.type == PROTO_ERROR ? m.error.message : proto_type_name(m.type));
    if (m.type != PROTO_ERROR)
        fail_msg("the include bomb was answered %s, not refused", proto_type_name(m.type));
    if (!strstr(m.error.message, "part.pbrt") || !strstr(m.error.message, "--max-text-mb"))
        fail_msg("the refusal \"%s\" does not name the file and --max-text-mb", m.error.message);
    proto_msg_free(&m);
    answer(&other, &m);
    if (m.type != PROTO_SUBMITTED)
        fail_msg("the other submission was answered %s: %s", proto_type_name(m.type),
                 m.type == PROTO_ERROR ? m.error.message : "");
    print_message("the other submission answered %.2f s after the first was sent\n",
                  clock_now_s() - t0);
    proto_msg_free(&m);
    client_close(&bomb);
    client_close(&other);
    testutil_stop(master, SIGTERM);
    free(part);
    free(main_text);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_vertex_bomb, testutil_kill_children),
        cmocka_unit_test_teardown(test_gzip_bomb, testutil_kill_children),
        cmocka_unit_test_teardown(test_include_bomb, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
