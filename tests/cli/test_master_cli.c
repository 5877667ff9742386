/* prismfarm master, run as a process ($PRISMFARM_BIN): exit codes (0 on SIGTERM, 1 for an
 * endpoint that cannot be bound, naming it, 2 for a bad command line), the endpoints file for
 * system-chosen ports, and a client served over tcp by the separate process. These masters run in
 * plain text (--insecure): the client here is a bare proto_net socket; test_curve checks keys. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cli_run.h"
#include "farm_testutil.h"

#include "net.h"

#include <fcntl.h>
#include <signal.h>
#include <time.h>
#include <zmq.h>

static void test_command_line(void **state)
{
    (void)state;
    const run_t *r = run("master", "--help", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "usage: prismfarm master");
    r = run("master", "--tile", "0", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--tile expects an integer in 1..4096, got '0'");
    r = run("master", "--heartbeat", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--heartbeat needs a value");
    r = run("master", "--frobnicate", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "unknown argument '--frobnicate'");
}

/* A port already taken: exit 1 with the endpoint in the message. */
static void test_port_in_use(void **state)
{
    (void)state;
    void *ctx = zmq_ctx_new();
    net_t *taken = net_new(ctx, NET_ROUTER, NULL, NULL);
    assert_non_null(taken);
    assert_int_equal(net_bind(taken, "tcp://127.0.0.1:*", NULL), 0);
    char ep[256];
    assert_int_equal(net_endpoint(taken, ep, sizeof ep, NULL), 0);
    const char *spool = testutil_scratch("port-spool");
    const run_t *r =
        run("master", "--workers", ep, "--clients", "tcp://127.0.0.1:*", "--spool", spool,
            "--insecure", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "workers endpoint");
    expect_in(r->err, ep);
    net_destroy(&taken);
    zmq_ctx_term(ctx);
}

/* A master process with system-chosen ports: it writes SPOOL/endpoints, answers a client over
 * tcp, and exits 0 soon after SIGTERM. */
static void test_serves_and_stops(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("spool");
    pid_t pid = testutil_spawn("/dev/null", "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                               "tcp://127.0.0.1:*", "--spool", spool, "--insecure", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, NULL);
    assert_non_null(strstr(cep, "tcp://127.0.0.1:"));

    void *ctx = zmq_ctx_new();
    net_t *c = net_new(ctx, NET_DEALER, NULL, NULL);
    assert_non_null(c);
    assert_int_equal(net_connect(c, cep, NULL), 0);
    proto_msg_t req = {.type = PROTO_JOBS}, reply;
    assert_int_equal(net_send(c, NULL, &req, NULL), 0);
    int rc = net_recv(c, NULL, &reply, test_wait_ms(), NULL);
    assert_int_equal(rc, 0);
    assert_int_equal(reply.type, PROTO_JOBS_REPLY);
    assert_int_equal(reply.jobs_reply.njobs, 0);
    proto_msg_free(&reply);
    net_destroy(&c);
    zmq_ctx_term(ctx);

    int status = testutil_stop(pid, SIGTERM);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
}

/* A second master on a spool that a running master holds refuses to start (exit 1), naming the
 * spool and the first one's pid, instead of handing out the same job ids into the same journal;
 * the first one goes on serving, and once it has stopped the spool can be used again. */
static void test_second_master_on_spool(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("shared-spool");
    pid_t first = testutil_spawn("/dev/null", "master", "--workers", "tcp://127.0.0.1:*",
                                 "--clients", "tcp://127.0.0.1:*", "--spool", spool, "--insecure",
                                 NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, NULL);
    const run_t *r = run("master", "--workers", "tcp://127.0.0.1:*", "--clients",
                         "tcp://127.0.0.1:*", "--spool", spool, "--insecure", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "in use by another master");
    expect_in(r->err, spool);
    char pid[32];
    snprintf(pid, sizeof pid, "pid %ld", (long)first);
    expect_in(r->err, pid);
    r = run("jobs", "--master", cep, "--insecure", NULL);
    assert_int_equal(r->status, 0);
    int status = testutil_stop(first, SIGTERM);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);

    /* The lock goes with its master. */
    char path[512];
    snprintf(path, sizeof path, "%s/endpoints", spool);
    unlink(path);
    pid_t next = testutil_spawn("/dev/null", "master", "--workers", "tcp://127.0.0.1:*",
                                "--clients", "tcp://127.0.0.1:*", "--spool", spool, "--insecure",
                                NULL);
    testutil_read_endpoints(spool, wep, cep, NULL);
    status = testutil_stop(next, SIGKILL);
    assert_true(WIFSIGNALED(status));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_command_line),
        cmocka_unit_test(test_port_in_use),
        cmocka_unit_test_teardown(test_serves_and_stops, testutil_kill_children),
        cmocka_unit_test_teardown(test_second_master_on_spool, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
