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
#include "clock.h"

#include "net.h"

#include <fcntl.h>
#include <signal.h>
#include <time.h>
#include <zmq.h>

static void sleep_ms(int ms)
{
    struct timespec ts = {.tv_sec = ms / 1000, .tv_nsec = (long)(ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

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
    char spool[] = "/tmp/prismfarm-test-master-cli-XXXXXX";
    assert_non_null(mkdtemp(spool));
    const run_t *r =
        run("master", "--workers", ep, "--clients", "tcp://127.0.0.1:*", "--spool", spool,
            "--insecure", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "workers endpoint");
    expect_in(r->err, ep);
    net_destroy(&taken);
    zmq_ctx_term(ctx);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", spool);
    assert_int_equal(system(cmd), 0);
}

/* A master process with system-chosen ports: it writes SPOOL/endpoints, answers a client over
 * tcp, and exits 0 soon after SIGTERM. */
static void test_serves_and_stops(void **state)
{
    (void)state;
    const char *bin = getenv("PRISMFARM_BIN");
    assert_non_null(bin);
    char spool[] = "/tmp/prismfarm-test-master-cli-XXXXXX";
    assert_non_null(mkdtemp(spool));
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int null = open("/dev/null", O_WRONLY);
        if (null >= 0)
            dup2(null, STDERR_FILENO);
        execl(bin, bin, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
              "tcp://127.0.0.1:*", "--spool", spool, "--insecure", (char *)NULL);
        _exit(127);
    }
    char path[128], line[300], cep[320] = "";
    snprintf(path, sizeof path, "%s/endpoints", spool);
    for (double until = clock_now_s() + test_wait_s(); !cep[0] && clock_now_s() < until;) {
        FILE *f = fopen(path, "r");
        if (f) {
            while (fgets(line, sizeof line, f))
                if (!strncmp(line, "clients ", 8)) {
                    line[strcspn(line, "\n")] = 0;
                    snprintf(cep, sizeof cep, "%s", line + 8);
                }
            fclose(f);
        }
        if (!cep[0])
            sleep_ms(10);
    }
    if (!cep[0]) {
        kill(pid, SIGKILL);
        fail_msg("the master wrote no endpoints file within %.0f s", test_wait_s());
    }
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

    assert_int_equal(kill(pid, SIGTERM), 0);
    int status = 0;
    pid_t got = 0;
    for (double until = clock_now_s() + test_wait_s(); got == 0 && clock_now_s() < until;) {
        got = waitpid(pid, &status, WNOHANG);
        if (got == 0)
            sleep_ms(10);
    }
    if (got != pid) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
        fail_msg("the master did not stop within %.0f s of SIGTERM", test_wait_s());
    }
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", spool);
    assert_int_equal(system(cmd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_command_line),
        cmocka_unit_test(test_port_in_use),
        cmocka_unit_test(test_serves_and_stops),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
