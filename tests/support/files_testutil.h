/* files_testutil: the file helpers the tests share. A scratch folder per test executable
 * (testutil_scratch_setup and testutil_scratch_teardown as cmocka's group setup and teardown,
 * testutil_scratch(NAME) for a path in it), or a fresh folder of one's own (testutil_mkdtemp,
 * testutil_path_in, testutil_rmtree). Header-only (each test is its own executable); include
 * after cmocka.h. */
#ifndef PRISMFARM_FILES_TESTUTIL_H
#define PRISMFARM_FILES_TESTUTIL_H

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

/* Makes a fresh folder /tmp/prismfarm-test-NAME-XXXXXX into dir; returns 0 or -1. */
static inline int testutil_mkdtemp(char *dir, size_t size, const char *name)
{
    snprintf(dir, size, "/tmp/prismfarm-test-%s-XXXXXX", name);
    return mkdtemp(dir) ? 0 : -1;
}

/* DIR/NAME in one of 16 rotating buffers: a test may hold that many paths at once (the
 * arguments of one command line) without managing their storage. A path too long for them
 * fails the test. */
static inline const char *testutil_path_in(const char *dir, const char *name)
{
    static char buf[16][512];
    static int k;
    k = (k + 1) % 16;
    if (snprintf(buf[k], sizeof buf[k], "%s/%s", dir, name) >= (int)sizeof buf[k])
        fail_msg("path %s/%s is longer than %zu bytes", dir, name, sizeof buf[k] - 1);
    return buf[k];
}

/* Removes the folder and everything in it; returns 0 or -1. */
static inline int testutil_rmtree(const char *dir)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* ------------------------------------------------------------------------------------------ */
/* The scratch folder: one for the whole test executable, /tmp/prismfarm-test-NAME-XXXXXX with
 * NAME the test's source file without "test_" and ".c" (test_cli_json.c: cli_json). */

/* The folder's storage; "" until testutil_scratch_setup made it. */
static inline char *testutil_scratch_buf(void)
{
    static char dir[256];
    return dir;
}

/* The scratch folder ("" before testutil_scratch_setup). */
static inline const char *testutil_scratch_dir(void)
{
    return testutil_scratch_buf();
}

/* Makes the scratch folder (a cmocka setup: group or per test); returns 0 or -1. */
static inline int testutil_scratch_setup(void **state)
{
    (void)state;
#ifdef __BASE_FILE__
    const char *file = __BASE_FILE__;
#else
    const char *file = "test_scratch.c";
#endif
    const char *base = strrchr(file, '/') ? strrchr(file, '/') + 1 : file;
    if (!strncmp(base, "test_", 5))
        base += 5;
    char name[64];
    snprintf(name, sizeof name, "%.*s", (int)strcspn(base, "."), base);
    return testutil_mkdtemp(testutil_scratch_buf(), 256, name);
}

/* Removes the scratch folder with everything in it (a cmocka teardown); returns 0 or -1. */
static inline int testutil_scratch_teardown(void **state)
{
    (void)state;
    char *dir = testutil_scratch_buf();
    if (!dir[0])
        return 0;
    int rc = testutil_rmtree(dir);
    dir[0] = '\0';
    return rc;
}

/* The path NAME in the scratch folder, in testutil_path_in's rotating buffers. */
static inline const char *testutil_scratch(const char *name)
{
    return testutil_path_in(testutil_scratch_dir(), name);
}

#endif
