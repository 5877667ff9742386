/* files_testutil: the file helpers the tests share. A scratch folder per test executable
 * (testutil_scratch_setup and testutil_scratch_teardown as cmocka's group setup and teardown,
 * testutil_scratch(NAME) for a path in it), or a fresh folder of one's own (testutil_mkdtemp,
 * testutil_path_in, testutil_rmtree); paths in the source tree; a whole file read into memory
 * (testutil_slurp), a text file written with a mode, a file cut short, a folder's entries counted,
 * a text looked for in a file (a log) and in a string, and a failure that quotes a file.
 * Header-only (each test is its own executable); include after cmocka.h. */
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

/* ------------------------------------------------------------------------------------------ */
/* The source tree. */

/* The source tree's folder: $PRISMFARM_SOURCE_DIR, which ctest sets, or "..", the parent of
 * tests/, where ctest runs the tests. */
static inline const char *testutil_source_dir(void)
{
    const char *src = getenv("PRISMFARM_SOURCE_DIR");
    return src ? src : "..";
}

/* The path REL in the source tree, in testutil_path_in's rotating buffers. */
static inline const char *testutil_source_path(const char *rel)
{
    return testutil_path_in(testutil_source_dir(), rel);
}

/* ------------------------------------------------------------------------------------------ */
/* Files. */

/* The whole file at path in a new buffer (malloc: the caller frees it), with a NUL after its
 * bytes; *size (if size is not NULL) gets their number, without the NUL. NULL, and *size 0, when
 * the file cannot be opened. Running out of memory fails the test. */
static inline char *testutil_slurp(const char *path, size_t *size)
{
    if (size)
        *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap + 1);
    for (size_t got; buf && (got = fread(buf + n, 1, cap - n, f)) > 0;) {
        n += got;
        if (n == cap) {
            char *p = realloc(buf, 2 * cap + 1);
            if (!p)
                free(buf);
            buf = p;
            cap *= 2;
        }
    }
    fclose(f);
    if (!buf)
        fail_msg("out of memory reading %s", path);
    buf[n] = '\0';
    if (size)
        *size = n;
    return buf;
}

/* How many times needle occurs in haystack (overlapping occurrences too). */
static inline int testutil_count_in(const char *haystack, const char *needle)
{
    int n = 0;
    for (const char *p = strstr(haystack, needle); p; p = strstr(p + 1, needle))
        n++;
    return n;
}

/* How many times the file at path (a log) holds needle; a file not there holds it 0 times. */
static inline int testutil_file_count(const char *path, const char *needle)
{
    char *text = testutil_slurp(path, NULL);
    int n = text ? testutil_count_in(text, needle) : 0;
    free(text);
    return n;
}

/* Whether the file at path (a log) holds needle; a file not there yet holds nothing. */
static inline int testutil_file_has(const char *path, const char *needle)
{
    char *text = testutil_slurp(path, NULL);
    int found = text && strstr(text, needle);
    free(text);
    return found;
}

/* Prints the whole file at path (a log) with cmocka's print_error, for a failure message, or
 * "(no file)" when there is none. */
static inline void testutil_print_file(const char *path)
{
    char *text = testutil_slurp(path, NULL);
    print_error("%s\n", text ? text : "(no file)");
    free(text);
}

/* fail_msg(fmt, ...) with the whole file at path (a log) quoted on the lines after the message.
 * The text is freed before the test fails, so that a failure adds no leak report of its own. */
#define testutil_fail_quoting(path, fmt, ...)                                                      \
    do {                                                                                           \
        print_error("ERROR: " fmt "\n", ##__VA_ARGS__);                                            \
        testutil_print_file(path);                                                                 \
        fail();                                                                                    \
    } while (0)

/* Fails the test, quoting the file, unless the file at path holds needle. */
#define testutil_expect_file_has(path, needle)                                                     \
    do {                                                                                           \
        const char *path_ = (path), *needle_ = (needle);                                           \
        if (!testutil_file_has(path_, needle_))                                                    \
            testutil_fail_quoting(path_, "expected '%s' in %s:", needle_, path_);                  \
    } while (0)

/* Writes text to the file at path (created or emptied) and gives the file the mode (chmod, so
 * whatever the umask); fails the test if any step does. */
static inline void testutil_write_text(const char *path, const char *text, mode_t mode)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, mode);
    if (fd < 0)
        fail_msg("cannot write %s: %s", path, strerror(errno));
    size_t len = strlen(text);
    assert_int_equal(write(fd, text, len), (ssize_t)len);
    assert_int_equal(fchmod(fd, mode), 0);
    assert_int_equal(close(fd), 0);
}

/* Writes the first keep bytes of the file src to dst: a file cut short. Fails the test unless
 * src has that many. */
static inline void testutil_truncate_copy(const char *src, const char *dst, long keep)
{
    FILE *in = fopen(src, "rb");
    assert_non_null(in);
    char *buf = malloc((size_t)keep);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)keep, in), (size_t)keep);
    fclose(in);
    FILE *out = fopen(dst, "wb");
    assert_non_null(out);
    assert_int_equal(fwrite(buf, 1, (size_t)keep, out), (size_t)keep);
    assert_int_equal(fclose(out), 0);
    free(buf);
}

/* The entries of a folder other than . and ..; -1 if it cannot be read. */
static inline int testutil_count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n;
}

#endif
