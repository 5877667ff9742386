/* diskfull_testutil: runs a piece of a test in a child process whose writes fail, and waits for
 * it with the overall deadline of test_wait.h, so that a writer that hangs on a write error (the
 * OpenEXRCore deadlock of issue 16) fails the test instead of hanging it. Two ways to make the
 * writes fail, neither needing a device node: a file-size limit (RLIMIT_FSIZE: every write past
 * it fails with EFBIG, any user, any file system), and a small tmpfs mounted in a private mount
 * namespace (ENOSPC, a real full disk; needs root or unprivileged user namespaces, else the test
 * is skipped with the reason). Header-only; include after cmocka.h. */
#ifndef PRISMFARM_DISKFULL_TESTUTIL_H
#define PRISMFARM_DISKFULL_TESTUTIL_H

#ifndef _GNU_SOURCE
#error "diskfull_testutil.h needs _GNU_SOURCE (syscall, mount flags)"
#endif

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <linux/sched.h> /* CLONE_*: <sched.h> is master/sched.h on the tests' include path */
#include <sys/syscall.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_wait.h"

/* What the child did: its function's status (0 passed), or DISKFULL_SKIP when the tmpfs could
 * not be mounted, and the message it wrote. */
#define DISKFULL_SKIP 77
typedef struct diskfull_result {
    int status;
    char msg[1024];
} diskfull_result_t;

/* The child's body: does the write, fills msg (what it saw), returns 0 when the write failed as
 * it should. */
typedef int (*diskfull_fn_t)(void *arg, char *msg, size_t size);

static inline int diskfull_write_file(const char *path, const char *text)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0)
        return -1;
    ssize_t n = write(fd, text, strlen(text));
    close(fd);
    return n == (ssize_t)strlen(text) ? 0 : -1;
}

/* In the child: a private mount namespace (entered as root, or through a user namespace that
 * maps us to root) with a tmpfs of size_kb KiB on dir. */
static inline int diskfull_mount_tmpfs(const char *dir, int size_kb, char *why, size_t size)
{
    uid_t uid = getuid();
    gid_t gid = getgid();
    if (syscall(SYS_unshare, uid == 0 ? CLONE_NEWNS : CLONE_NEWUSER | CLONE_NEWNS) != 0) {
        snprintf(why, size, "unshare: %s (not root and no unprivileged user namespaces)",
                 strerror(errno));
        return -1;
    }
    if (uid != 0) {
        char map[64];
        snprintf(map, sizeof map, "0 %u 1\n", (unsigned)uid);
        if (diskfull_write_file("/proc/self/setgroups", "deny") != 0 ||
            diskfull_write_file("/proc/self/uid_map", map) != 0) {
            snprintf(why, size, "cannot map our uid in the user namespace: %s", strerror(errno));
            return -1;
        }
        snprintf(map, sizeof map, "0 %u 1\n", (unsigned)gid);
        (void)diskfull_write_file("/proc/self/gid_map", map);
    }
    if (mount(NULL, "/", NULL, MS_REC | MS_PRIVATE, NULL) != 0) {
        snprintf(why, size, "cannot make the mounts private: %s", strerror(errno));
        return -1;
    }
    char opts[64];
    snprintf(opts, sizeof opts, "size=%dk,mode=0777", size_kb);
    if (mount("tmpfs", dir, "tmpfs", 0, opts) != 0) {
        snprintf(why, size, "cannot mount a tmpfs on %s: %s", dir, strerror(errno));
        return -1;
    }
    return 0;
}

/* Runs fn(arg) in a child: with a file-size limit of fsize_limit bytes when tmpfs_dir is NULL,
 * else with a tmpfs of tmpfs_kb KiB mounted on tmpfs_dir (only the child sees it). Waits for the
 * child's answer at most test_wait_s(); a child still silent then is killed and the test fails
 * (a hang). */
static inline diskfull_result_t diskfull_run(diskfull_fn_t fn, void *arg, long fsize_limit,
                                             const char *tmpfs_dir, int tmpfs_kb)
{
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(fds[0]);
        char msg[1024] = "";
        int status;
        if (tmpfs_dir) {
            status = diskfull_mount_tmpfs(tmpfs_dir, tmpfs_kb, msg, sizeof msg) == 0
                         ? fn(arg, msg, sizeof msg)
                         : DISKFULL_SKIP;
        } else {
            signal(SIGXFSZ, SIG_IGN); /* a write past the limit fails with EFBIG instead */
            struct rlimit rl;
            getrlimit(RLIMIT_FSIZE, &rl);
            rl.rlim_cur = (rlim_t)fsize_limit;
            status = setrlimit(RLIMIT_FSIZE, &rl) == 0 ? fn(arg, msg, sizeof msg) : 1;
        }
        (void)!write(fds[1], msg, strlen(msg) + 1);
        _exit(status);
    }
    close(fds[1]);
    diskfull_result_t res = {.status = -1, .msg = ""};
    size_t used = 0;
    for (;;) {
        struct pollfd p = {.fd = fds[0], .events = POLLIN};
        int ready = poll(&p, 1, test_wait_ms());
        if (ready < 0 && errno == EINTR)
            continue;
        if (ready == 0) {
            kill(pid, SIGKILL);
            waitpid(pid, NULL, 0);
            close(fds[0]);
            fail_msg("the writer gave no answer within %.0f s of a write error: it hangs",
                     test_wait_s());
        }
        ssize_t n = read(fds[0], res.msg + used, sizeof res.msg - 1 - used);
        if (n <= 0)
            break;
        used += (size_t)n;
    }
    close(fds[0]);
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    res.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return res;
}

#endif
