/* bad-input gallery (tests/bad/, README.md there): every broken scene, broken PLY file, confined
 * escape and malformed message listed in tests/bad/MANIFEST fails with exactly the error the
 * manifest gives: a scene's message starts with its "file:line:col" and contains the expected
 * text; a message decodes to the expected code (PROTO_EMALFORMED or PROTO_EVERSION) with the
 * expected text. Nothing may crash, hang or leak: each entry runs in this process (so the
 * sanitizer build's leak check covers it) under an alarm, and must refuse its input within
 * ENTRY_CPU_SECONDS_MAX of CPU time. Every gallery file must be listed, so none is silently
 * skipped.
 *
 * With PRISMFARM_BAD_PRINT=1 in the environment, prints each entry's actual error instead of
 * failing on a mismatch (for writing new entries). Runs with the working directory tests/. */
#define _XOPEN_SOURCE 700 /* opendir, strdup */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <ctype.h>
#include <dirent.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "files_testutil.h"
#include "proto.h"
#include "scene_load.h"

/* Each entry reads at most a few kilobytes; under ASan the slowest takes a few milliseconds
 * (measured: see the summary line). An entry still running after ALARM_S seconds has hung (the
 * alarm kills the test; wall time, generous for a loaded machine); one that used more than
 * ENTRY_CPU_SECONDS_MAX of CPU did work it should have refused to do (reading /dev/zero,
 * allocating from a forged count). CPU time, not wall time: a machine busy with other work
 * stretches the wall time of an entry, never the CPU time it takes. */
#define ALARM_S 120
#define ENTRY_CPU_SECONDS_MAX 2.0

/* The gallery must keep at least these many entries of each kind (25 broken scenes at the
 * least, and as many malformed messages), so that it cannot quietly shrink. */
#define MIN_SCENES 25
#define MIN_MESSAGES 25

typedef enum kind { KIND_SCENE, KIND_CONFINED, KIND_MSG } kind_t;

typedef struct entry {
    kind_t kind;
    char *file;  /* relative to tests/bad */
    char *where; /* scenes: the location prefix, or "-"; messages: "EMALFORMED" / "EVERSION" */
    char *text;  /* a fragment the message must contain */
    int line;    /* in MANIFEST */
} entry_t;

typedef struct gallery {
    entry_t *entries;
    size_t n;
    bool print; /* PRISMFARM_BAD_PRINT */
    double slowest;
    const char *slowest_file;
} gallery_t;

/* CPU seconds this process has used (every thread: a loader may start some). */
static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static char *trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    size_t n = strlen(s);
    while (n > 0 && isspace((unsigned char)s[n - 1]))
        s[--n] = 0;
    return s;
}

/* "kind | file | where | text": the first three " | " split; the text is the rest. */
static void parse_manifest(gallery_t *g)
{
    FILE *f = fopen("MANIFEST", "r");
    if (!f)
        fail_msg("cannot open tests/bad/MANIFEST");
    char buf[2048];
    int line = 0;
    size_t cap = 0;
    while (fgets(buf, sizeof buf, f)) {
        line++;
        assert_non_null(strchr(buf, '\n'));
        char *s = trim(buf);
        if (!*s || *s == '#')
            continue;
        char *field[4];
        for (int i = 0; i < 3; i++) {
            char *bar = strstr(s, " | ");
            if (!bar)
                fail_msg("MANIFEST:%d: expected \"kind | file | where | text\"", line);
            *bar = 0;
            field[i] = trim(s);
            s = bar + 3;
        }
        field[3] = trim(s);
        entry_t e = {.line = line};
        if (!strcmp(field[0], "scene"))
            e.kind = KIND_SCENE;
        else if (!strcmp(field[0], "confined"))
            e.kind = KIND_CONFINED;
        else if (!strcmp(field[0], "msg"))
            e.kind = KIND_MSG;
        else
            fail_msg("MANIFEST:%d: unknown kind \"%s\"", line, field[0]);
        if (!*field[3])
            fail_msg("MANIFEST:%d: no expected text", line);
        e.file = strdup(field[1]);
        e.where = strdup(field[2]);
        e.text = strdup(field[3]);
        assert_true(e.file && e.where && e.text);
        if (g->n == cap) {
            cap = cap ? 2 * cap : 64;
            g->entries = realloc(g->entries, cap * sizeof *g->entries);
            assert_non_null(g->entries);
        }
        g->entries[g->n++] = e;
    }
    assert_int_equal(fclose(f), 0);
}

static int setup(void **state)
{
    const char *dir = testutil_source_path("tests/bad");
    if (chdir(dir) != 0) {
        fprintf(stderr, "cannot enter %s\n", dir);
        return -1;
    }
    gallery_t *g = calloc(1, sizeof *g);
    if (!g)
        return -1;
    const char *p = getenv("PRISMFARM_BAD_PRINT");
    g->print = p && *p && strcmp(p, "0") != 0;
    parse_manifest(g);
    *state = g;
    return 0;
}

static int teardown(void **state)
{
    gallery_t *g = *state;
    for (size_t i = 0; i < g->n; i++) {
        free(g->entries[i].file);
        free(g->entries[i].where);
        free(g->entries[i].text);
    }
    free(g->entries);
    free(g);
    return 0;
}

/* ---------------------------------------------------------------- running one entry */

/* Hex bytes after '#' comment lines; whitespace between bytes is ignored. */
static uint8_t *read_hex(const char *path, size_t *len)
{
    FILE *f = fopen(path, "r");
    if (!f)
        fail_msg("cannot open %s", path);
    size_t cap = 256, n = 0;
    uint8_t *out = malloc(cap);
    assert_non_null(out);
    char line[1024];
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#')
            continue;
        for (char *p = line; *p;) {
            if (isspace((unsigned char)*p)) {
                p++;
                continue;
            }
            unsigned v;
            if (!isxdigit((unsigned char)p[0]) || !isxdigit((unsigned char)p[1]) ||
                sscanf(p, "%2x", &v) != 1)
                fail_msg("%s: not a hex byte at \"%.8s\"", path, p);
            if (n == cap) {
                cap *= 2;
                out = realloc(out, cap);
                assert_non_null(out);
            }
            out[n++] = (uint8_t)v;
            p += 2;
        }
    }
    assert_int_equal(fclose(f), 0);
    *len = n;
    return out;
}

static char *folder_of(const char *file)
{
    char *d = strdup(file);
    assert_non_null(d);
    char *slash = strrchr(d, '/');
    if (slash)
        *slash = 0;
    else
        strcpy(d, ".");
    return d;
}

static const char *code_name(int rc)
{
    return rc == PROTO_EMALFORMED ? "EMALFORMED" : rc == PROTO_EVERSION ? "EVERSION" : "?";
}

/* Runs one entry; returns whether it failed as expected (printing why not). */
static bool run_entry(gallery_t *g, const entry_t *e)
{
    err_t err = {{0}};
    char got_where[64] = "";
    bool refused;
    alarm(ALARM_S);
    double t0 = cpu_s();
    if (e->kind == KIND_MSG) {
        size_t len;
        uint8_t *data = read_hex(e->file, &len);
        proto_msg_t m;
        int rc = proto_decode(data, len, NULL, &m, &err);
        proto_msg_free(&m);
        free(data);
        refused = rc != 0;
        snprintf(got_where, sizeof got_where, "%s", rc ? code_name(rc) : "accepted");
    } else {
        scene_t *sc;
        if (e->kind == KIND_CONFINED) {
            char *root = folder_of(e->file);
            sc = scene_load_file_confined(e->file, root, NULL, &err);
            free(root);
        } else {
            sc = scene_load_file(e->file, NULL, &err);
        }
        refused = sc == NULL;
        scene_destroy(&sc);
    }
    double dt = cpu_s() - t0;
    alarm(0);
    if (dt > g->slowest) {
        g->slowest = dt;
        g->slowest_file = e->file;
    }
    if (g->print) {
        printf("%s | %s | %s\n", e->file, e->kind == KIND_MSG ? got_where : "-",
               refused ? err.msg : "(accepted)");
        return true;
    }
    bool ok = refused && strstr(err.msg, e->text) != NULL;
    if (e->kind == KIND_MSG) {
        ok = ok && !strcmp(got_where, e->where);
    } else if (strcmp(e->where, "-") != 0) {
        size_t n = strlen(e->where);
        ok = ok && !strncmp(err.msg, e->where, n) && !strncmp(err.msg + n, ": ", 2);
    }
    if (!ok)
        fprintf(stderr, "MANIFEST:%d: %s\n  expected: %s: ...%s...\n  got:      %s%s%s\n", e->line,
                e->file, e->where, e->text, e->kind == KIND_MSG ? got_where : "",
                e->kind == KIND_MSG ? ": " : "", refused ? err.msg : "(accepted: no error)");
    if (dt > ENTRY_CPU_SECONDS_MAX) {
        fprintf(stderr, "MANIFEST:%d: %s took %.2f s of CPU, more than %.1f s\n", e->line, e->file,
                dt, ENTRY_CPU_SECONDS_MAX);
        ok = false;
    }
    return ok;
}

static void run_kind(void **state, kind_t a, kind_t b, size_t min, const char *what)
{
    gallery_t *g = *state;
    size_t n = 0, bad = 0;
    g->slowest = 0;
    g->slowest_file = NULL;
    for (size_t i = 0; i < g->n; i++) {
        const entry_t *e = &g->entries[i];
        if (e->kind != a && e->kind != b)
            continue;
        n++;
        bad += !run_entry(g, e);
    }
    print_message("%zu %s, %zu not as expected; slowest %.3f CPU s (%s)\n", n, what, bad,
                  g->slowest, g->slowest_file ? g->slowest_file : "-");
    assert_int_equal(bad, 0);
    assert_true(n >= min);
}

static void test_scenes(void **state)
{
    run_kind(state, KIND_SCENE, KIND_CONFINED, MIN_SCENES, "broken scenes");
}

static void test_messages(void **state)
{
    run_kind(state, KIND_MSG, KIND_MSG, MIN_MESSAGES, "malformed messages");
}

/* Every scene and message file of the gallery has an entry (included files and PLY meshes, in
 * subfolders, are reached through the scenes that name them). */
static void check_listed(const gallery_t *g, const char *dir, const char *suffix)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    for (struct dirent *de; (de = readdir(d));) {
        size_t n = strlen(de->d_name), s = strlen(suffix);
        if (n <= s || strcmp(de->d_name + n - s, suffix) != 0)
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, de->d_name);
        bool listed = false;
        for (size_t i = 0; i < g->n && !listed; i++)
            listed = !strcmp(g->entries[i].file, path);
        if (!listed)
            fail_msg("tests/bad/%s has no entry in tests/bad/MANIFEST", path);
    }
    closedir(d);
}

static void test_every_file_listed(void **state)
{
    const gallery_t *g = *state;
    check_listed(g, "scenes", ".pbrt");
    check_listed(g, "confined/root", ".pbrt");
    check_listed(g, "messages", ".hex");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_file_listed),
        cmocka_unit_test(test_scenes),
        cmocka_unit_test(test_messages),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
