/* cli_run: runs the prismfarm executable ($PRISMFARM_BIN, set by ctest) as a child process
 * for the command-line tests, capturing stdout and stderr separately, and expect_in for a text
 * a test expects in an output. Header-only: each CLI test is its own executable. Include after
 * cmocka.h. */
#ifndef PRISMFARM_CLI_RUN_H
#define PRISMFARM_CLI_RUN_H

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_wait.h"

/* How long a command may stay silent (no output, not exited) before it is taken for hung,
 * killed and the test failed: a test's own CLI_RUN_TIMEOUT_MS for its long renders, and never
 * less than the overall deadline of a wait (test_wait.h), so that a loaded machine's slowness
 * is never read as a hang. */
#ifndef CLI_RUN_TIMEOUT_MS
#define CLI_RUN_TIMEOUT_MS 0
#endif
static inline int cli_run_timeout_ms(void)
{
    return CLI_RUN_TIMEOUT_MS > test_wait_ms() ? CLI_RUN_TIMEOUT_MS : test_wait_ms();
}

#define OUT_MAX 65536

typedef struct run {
    int status; /* exit code, or -1 if the process did not exit normally */
    char out[OUT_MAX];
    char err[OUT_MAX];
} run_t;

/* Fills argv (size entries) with bin, then first and the NULL-terminated arguments after it,
 * then NULL; arguments beyond the room are dropped. */
static inline void cli_argv(char **argv, int size, const char *bin, const char *first, va_list rest)
{
    int argc = 0;
    argv[argc++] = (char *)bin;
    for (const char *a = first; a && argc < size - 1; a = va_arg(rest, const char *))
        argv[argc++] = (char *)a;
    argv[argc] = NULL;
}

/* The one run at a time: large buffers stay off the stack. */
static inline run_t *cli_run_result(void)
{
    static run_t result;
    return &result;
}

/* Runs $PRISMFARM_BIN with the given arguments (NULL-terminated), capturing stdout and
 * stderr separately (poll, so neither pipe can fill and block the child). */
static inline const run_t *run(const char *arg, ...)
{
    const char *bin = getenv("PRISMFARM_BIN");
    if (!bin)
        fail_msg("PRISMFARM_BIN is not set (run the test through ctest)");
    char *argv[32];
    va_list ap;
    va_start(ap, arg);
    cli_argv(argv, 32, bin, arg, ap);
    va_end(ap);

    int out_pipe[2], err_pipe[2];
    assert_int_equal(pipe(out_pipe), 0);
    assert_int_equal(pipe(err_pipe), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        dup2(out_pipe[1], STDOUT_FILENO);
        dup2(err_pipe[1], STDERR_FILENO);
        close(out_pipe[0]);
        close(out_pipe[1]);
        close(err_pipe[0]);
        close(err_pipe[1]);
        execv(bin, argv);
        _exit(127);
    }
    close(out_pipe[1]);
    close(err_pipe[1]);
    run_t *result = cli_run_result();
    memset(result, 0, sizeof *result);
    size_t used[2] = {0, 0};
    char *bufs[2] = {result->out, result->err};
    struct pollfd fds[2] = {{.fd = out_pipe[0], .events = POLLIN},
                            {.fd = err_pipe[0], .events = POLLIN}};
    int open_fds = 2;
    while (open_fds > 0) {
        int ready = poll(fds, 2, cli_run_timeout_ms());
        if (ready < 0 && errno == EINTR)
            continue;
        if (ready <= 0) {
            int st;
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
            for (int k = 0; k < 2; k++)
                if (fds[k].fd >= 0)
                    close(fds[k].fd);
            fail_msg("prismfarm %s said nothing for %d ms and did not exit: killed", arg,
                     cli_run_timeout_ms());
        }
        for (int k = 0; k < 2; k++) {
            if (fds[k].fd < 0 || !(fds[k].revents & (POLLIN | POLLHUP | POLLERR)))
                continue;
            char chunk[4096];
            ssize_t got = read(fds[k].fd, chunk, sizeof chunk);
            if (got <= 0) {
                close(fds[k].fd);
                fds[k].fd = -1;
                open_fds--;
                continue;
            }
            size_t room = OUT_MAX - 1 - used[k];
            size_t take = (size_t)got < room ? (size_t)got : room;
            memcpy(bufs[k] + used[k], chunk, take);
            used[k] += take;
        }
    }
    int wstatus;
    assert_int_equal(waitpid(pid, &wstatus, 0), pid);
    result->status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1;
    return result;
}

static inline void expect_in(const char *haystack, const char *needle)
{
    if (!strstr(haystack, needle))
        fail_msg("expected '%s' in output:\n%s", needle, haystack);
}

#endif
