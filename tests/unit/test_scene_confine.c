/* scene confinement (pbrt_parse_file_confined, scene_load_file_confined): a scene from a bundle
 * reads only regular files inside its folder. A bundle folder whose scene names a file outside
 * ("../outside.pbrt", "/etc/passwd", a symbolic link to /etc/hostname or to /dev/zero, a
 * linked folder that leads out), a FIFO, a directory or an oversized file fails with its exact
 * message, fast; PLY files whose counts are not backed by their bytes (2^31 vertices in a
 * 200-byte file, a list of 2^32 - 1 indices) and a PNG that would decode to 4 G pixels are
 * refused before anything allocates; a legitimate scene with includes in subfolders, a PLY
 * reached with "..", a PNG and an inside symbolic link still loads.
 *
 * Every refusal runs in a child process under alarm(): a regression that opens the FIFO (which
 * blocks for ever), reads /dev/zero or lets assimp loop over 2^31 missing lines is killed and
 * reported as a hang instead of hanging CI. Runs with the working directory tests/. */
#define _XOPEN_SOURCE 700 /* mkdtemp, mkfifo, symlink, realpath */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <errno.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "files_testutil.h"
#include "image_png.h"
#include "mesh_import.h"
#include "pbrt_parser.h"
#include "scene_load.h"

/* A refusal touches a handful of small files: at most 0.08 s per case under ASan (fork
 * included, measured). A child still running after ALARM_S seconds of wall time has hung (a
 * generous bound: a loaded machine stretches wall time); one that used more than FAST_S of CPU
 * time did work it should not have (reading /dev/zero up to the 512 MiB bound takes seconds of
 * CPU). CPU time, the child's own, does not grow while other work has the cores. */
#define ALARM_S 120
#define FAST_S 1.0

typedef struct fixture {
    char base[64];    /* /tmp/prismfarm-test-confine-XXXXXX */
    char bundle[128]; /* base/bundle: the scene's folder */
} fixture_t;

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        fail_msg("cannot write %s: %s", path, strerror(errno));
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static void in_bundle(const fixture_t *fx, const char *name, char *out, size_t n)
{
    int w = snprintf(out, n, "%s/%s", fx->bundle, name);
    assert_true(w > 0 && (size_t)w < n);
}

/* ---- a parse in a child process ---- */

typedef struct outcome {
    bool ok;    /* the job succeeded */
    bool hung;  /* killed by the alarm */
    int signal; /* another signal that ended the child, or 0 */
    char msg[600];
    double seconds; /* CPU time, user and system */
} outcome_t;

typedef int (*job_fn)(const void *arg, err_t *err);

static double cpu_of(const struct rusage *r)
{
    return (double)r->ru_utime.tv_sec + 1e-6 * (double)r->ru_utime.tv_usec +
           (double)r->ru_stime.tv_sec + 1e-6 * (double)r->ru_stime.tv_usec;
}

static outcome_t run_in_child(job_fn job, const void *arg)
{
    outcome_t o = {0};
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    struct rusage before, after;
    assert_int_equal(getrusage(RUSAGE_CHILDREN, &before), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(fds[0]);
        alarm(ALARM_S);
#ifndef __SANITIZE_ADDRESS__
        /* A regression that lets assimp size an array from a forged count fails to allocate
         * here instead of paging the machine out (ASan needs its huge shadow mapping, so a
         * sanitizer build relies on the alarm and on ASan's own allocation limit). */
        struct rlimit as = {(rlim_t)4 << 30, (rlim_t)4 << 30};
        setrlimit(RLIMIT_AS, &as);
#endif
        err_t err = {{0}};
        char out[sizeof err.msg + 1];
        int rc = job(arg, &err);
        snprintf(out, sizeof out, "%c%s", rc == 0 ? '1' : '0', rc == 0 ? "" : err.msg);
        size_t n = strlen(out), done = 0;
        while (done < n) {
            ssize_t w = write(fds[1], out + done, n - done);
            if (w <= 0)
                break;
            done += (size_t)w;
        }
        _exit(0);
    }
    close(fds[1]);
    char buf[sizeof o.msg + 1];
    size_t n = 0;
    for (;;) {
        ssize_t r = read(fds[0], buf + n, sizeof buf - 1 - n);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            break;
        n += (size_t)r;
    }
    buf[n] = 0;
    close(fds[0]);
    int status;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    /* The children this process has reaped, less those before: this one. */
    assert_int_equal(getrusage(RUSAGE_CHILDREN, &after), 0);
    o.seconds = cpu_of(&after) - cpu_of(&before);
    if (WIFSIGNALED(status)) {
        o.hung = WTERMSIG(status) == SIGALRM;
        o.signal = WTERMSIG(status);
        return o;
    }
    o.ok = n > 0 && buf[0] == '1';
    snprintf(o.msg, sizeof o.msg, "%s", n > 0 ? buf + 1 : "(the child said nothing)");
    return o;
}

typedef struct parse_job {
    const char *path, *root;
} parse_job_t;

static int job_parse(const void *arg, err_t *err)
{
    const parse_job_t *j = arg;
    scene_desc_t *d = pbrt_parse_file_confined(j->path, j->root, NULL, err);
    if (!d)
        return -1;
    scene_desc_destroy(&d);
    return 0;
}

typedef struct ply_job {
    const char *data;
    size_t len;
    const char *name;
} ply_job_t;

static int job_ply_memory(const void *arg, err_t *err)
{
    const ply_job_t *j = arg;
    mesh_data_t m;
    int rc = mesh_import_ply_memory(j->data, j->len, j->name, &m, err);
    if (rc == 0)
        mesh_data_free(&m);
    return rc;
}

static void expect_outcome(outcome_t o, const char *what, const char *expected)
{
    if (o.hung)
        fail_msg("%s hung: killed by alarm() after %d s", what, ALARM_S);
    if (o.signal)
        fail_msg("%s crashed with signal %d", what, o.signal);
    if (o.ok)
        fail_msg("%s succeeded but should have failed with: %s", what, expected);
    if (strcmp(o.msg, expected) != 0)
        fail_msg("%s: wrong message\n  got:      %s\n  expected: %s", what, o.msg, expected);
    if (o.seconds > FAST_S)
        fail_msg("%s took %.3f s of CPU to fail (more than %.2f s)", what, o.seconds, FAST_S);
}

/* Writes the bundle's scene.pbrt with text and expects the confined parse to fail with
 * "<bundle>/scene.pbrt:" + located. */
static void expect_refused(const fixture_t *fx, const char *text, const char *located)
{
    char path[256], expected[700];
    in_bundle(fx, "scene.pbrt", path, sizeof path);
    testutil_write_text(path, text, 0644);
    snprintf(expected, sizeof expected, "%s:%s", path, located);
    parse_job_t j = {path, fx->bundle};
    expect_outcome(run_in_child(job_parse, &j), text, expected);
}

/* ---- the bundle ---- */

/* base/outside.pbrt is a valid scene fragment, so that a parse that read it would succeed
 * rather than fail for some other reason. Inside: sub/inc.pbrt includes deeper/more.pbrt
 * (relative to itself), names the texture tex/t.png (found in the main folder, pbrt-v4's rule)
 * and the mesh ../meshes/tri.ply (a ".." that stays inside); alias.pbrt links to
 * sub/deeper/more.pbrt. */
static int setup(void **state)
{
    fixture_t *fx = calloc(1, sizeof *fx);
    assert_non_null(fx);
    assert_int_equal(testutil_mkdtemp(fx->base, sizeof fx->base, "confine"), 0);
    snprintf(fx->bundle, sizeof fx->bundle, "%s/bundle", fx->base);
    char p[256];
    const char *dirs[] = {"", "/sub", "/sub/deeper", "/meshes", "/tex"};
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++) {
        snprintf(p, sizeof p, "%s%s", fx->bundle, dirs[i]);
        assert_int_equal(mkdir(p, 0700), 0);
    }
    snprintf(p, sizeof p, "%s/outside.pbrt", fx->base);
    testutil_write_text(p, "AttributeBegin\nAttributeEnd\n", 0644);
    snprintf(p, sizeof p, "%s/outside.ply", fx->base);
    testutil_write_text(
        p,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        0644);

    in_bundle(fx, "main.pbrt", p, sizeof p);
    testutil_write_text(p,
                        "LookAt 0 0 -5  0 0 0  0 1 0\n"
                        "Camera \"perspective\" \"float fov\" 45\n"
                        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                        "WorldBegin\n"
                        "LightSource \"point\" \"point3 from\" [0 0 -4]\n"
                        "Include \"sub/inc.pbrt\"\n"
                        "Include \"alias.pbrt\"\n",
                        0644);
    in_bundle(fx, "sub/inc.pbrt", p, sizeof p);
    testutil_write_text(
        p,
        "Include \"deeper/more.pbrt\"\n"
        "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"tex/t.png\"\n"
        "Material \"diffuse\" \"texture reflectance\" \"t\"\n"
        "Shape \"plymesh\" \"string filename\" \"../meshes/tri.ply\"\n",
        0644);
    in_bundle(fx, "sub/deeper/more.pbrt", p, sizeof p);
    testutil_write_text(p, "Shape \"sphere\" \"float radius\" 0.5\n", 0644);
    in_bundle(fx, "meshes/tri.ply", p, sizeof p);
    testutil_write_text(
        p,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        0644);
    in_bundle(fx, "tex/t.png", p, sizeof p);
    uint8_t rgb[6] = {128, 128, 128, 200, 100, 0};
    err_t err;
    assert_int_equal(image_png_write_rgb(p, 2, 1, rgb, &err), 0);
    in_bundle(fx, "alias.pbrt", p, sizeof p);
    assert_int_equal(symlink("sub/deeper/more.pbrt", p), 0);

    /* What a hostile bundle could hold if its extraction let it (the farm's does not): links
     * out, a FIFO, and a folder where a file is expected. */
    in_bundle(fx, "host", p, sizeof p);
    assert_int_equal(symlink("/etc/hostname", p), 0);
    in_bundle(fx, "zero.ply", p, sizeof p);
    assert_int_equal(symlink("/dev/zero", p), 0);
    in_bundle(fx, "zero.png", p, sizeof p);
    assert_int_equal(symlink("/dev/zero", p), 0);
    in_bundle(fx, "up", p, sizeof p);
    assert_int_equal(symlink("..", p), 0);
    in_bundle(fx, "fifo", p, sizeof p);
    assert_int_equal(mkfifo(p, 0600), 0);
    in_bundle(fx, "fifo.png", p, sizeof p);
    assert_int_equal(mkfifo(p, 0600), 0);
    in_bundle(fx, "fifo.ply", p, sizeof p);
    assert_int_equal(mkfifo(p, 0600), 0);
    *state = fx;
    return 0;
}

static int teardown(void **state)
{
    fixture_t *fx = *state;
    if (testutil_rmtree(fx->base) != 0)
        fprintf(stderr, "could not remove %s\n", fx->base);
    free(fx);
    return 0;
}

/* ---- files outside the folder, and files that are not regular ---- */

static void test_outside_and_special_files(void **state)
{
    const fixture_t *fx = *state;
    /* "Include " is 8 columns, so the name starts at column 9; a plymesh or imagemap file
     * name is located at its "string filename" declaration, as every parameter: column 17
     * after `Shape "plymesh" `, 35 after `Texture "t" "spectrum" "imagemap" `. */
    expect_refused(fx, "Include \"../outside.pbrt\"\n",
                   "1:9: \"../outside.pbrt\" is outside the scene's folder");
    expect_refused(fx, "Include \"sub/../../outside.pbrt\"\n",
                   "1:9: \"sub/../../outside.pbrt\" is outside the scene's folder");
    expect_refused(fx, "Include \"/etc/passwd\"\n",
                   "1:9: \"/etc/passwd\" is outside the scene's folder");
    expect_refused(fx, "WorldBegin\nImport \"../outside.pbrt\"\n",
                   "2:8: \"../outside.pbrt\" is outside the scene's folder");
    /* Lexically inside, outside once the links are followed. */
    expect_refused(fx, "Include \"host\"\n", "1:9: \"host\" is outside the scene's folder");
    expect_refused(fx, "Include \"up/outside.pbrt\"\n",
                   "1:9: \"up/outside.pbrt\" is outside the scene's folder");
    expect_refused(fx, "Include \"fifo\"\n", "1:9: \"fifo\" is not a regular file");
    expect_refused(fx, "Include \"sub\"\n", "1:9: \"sub\" is not a regular file");

    expect_refused(fx, "WorldBegin\nShape \"plymesh\" \"string filename\" \"/dev/zero\"\n",
                   "2:17: \"/dev/zero\" is outside the scene's folder");
    expect_refused(fx, "WorldBegin\nShape \"plymesh\" \"string filename\" \"zero.ply\"\n",
                   "2:17: \"zero.ply\" is outside the scene's folder");
    expect_refused(fx, "WorldBegin\nShape \"plymesh\" \"string filename\" \"../outside.ply\"\n",
                   "2:17: \"../outside.ply\" is outside the scene's folder");
    expect_refused(fx, "WorldBegin\nShape \"plymesh\" \"string filename\" \"fifo.ply\"\n",
                   "2:17: \"fifo.ply\" is not a regular file");
    /* An imagemap must be named *.png, so /dev/zero is reached through a link. */
    expect_refused(fx,
                   "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                   "\"zero.png\"\n",
                   "2:35: \"zero.png\" is outside the scene's folder");
    expect_refused(fx,
                   "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                   "\"/dev/zero.png\"\n",
                   "2:35: \"/dev/zero.png\" is outside the scene's folder");
    expect_refused(fx,
                   "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                   "\"fifo.png\"\n",
                   "2:35: \"fifo.png\" is not a regular file");

    /* The main file itself: no location, its path as given. */
    char path[256], expected[400];
    snprintf(path, sizeof path, "%s/outside.pbrt", fx->base);
    parse_job_t j = {path, fx->bundle};
    snprintf(expected, sizeof expected, "\"%s\" is outside the scene's folder", path);
    expect_outcome(run_in_child(job_parse, &j), "main file outside", expected);
    in_bundle(fx, "fifo", path, sizeof path);
    snprintf(expected, sizeof expected, "\"%s\" is not a regular file", path);
    expect_outcome(run_in_child(job_parse, &j), "main file a FIFO", expected);
}

/* A file over PBRT_FILE_BYTES_MAX is refused from its size alone: a sparse file of
 * 512 MiB + 1 byte takes no disk space and is never read. */
static void test_file_size_bound(void **state)
{
    const fixture_t *fx = *state;
    char path[256];
    in_bundle(fx, "huge.pbrt", path, sizeof path);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(truncate(path, (off_t)(512 << 20) + 1), 0);
    expect_refused(fx, "Include \"huge.pbrt\"\n",
                   "1:9: \"huge.pbrt\" is larger than 536870912 bytes");
    assert_int_equal(unlink(path), 0);
}

/* A PNG whose IHDR claims 65535 x 65535 pixels (PNG specification 11.2.2: signature, then
 * the IHDR chunk, width and height big-endian) would decode to 65535^2 = 4294836225 RGBA
 * pixels; the parse refuses it from its first 24 bytes. */
static void test_png_pixel_bound(void **state)
{
    const fixture_t *fx = *state;
    static const unsigned char png[33] = {
        0x89, 'P', 'N',  'G',  '\r', '\n', 0x1a, '\n', /* signature */
        0,    0,   0,    13,   'I',  'H',  'D',  'R',  /* chunk length 13, type */
        0,    0,   0xff, 0xff, 0,    0,    0xff, 0xff, /* width, height: 65535 */
        8,    6,   0,    0,    0,                      /* 8-bit RGBA */
        0,    0,   0,    0};                           /* CRC (never read) */
    char path[256];
    in_bundle(fx, "bomb.png", path, sizeof path);
    write_bytes(path, png, sizeof png);
    expect_refused(fx,
                   "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                   "\"bomb.png\"\n",
                   "2:35: image \"bomb.png\" decodes to 4294836225 pixels, more than the scene "
                   "may read (2147483648 bytes in all)");
    assert_int_equal(unlink(path), 0);
}

/* ---- PLY counts backed by bytes ---- */

static const char PLY_BOMB_HEADER[] =
    "ply\nformat ascii 1.0\ncomment 2G\n"
    "element vertex 2147483648\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
static const char PLY_BOMB_BODY[] = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

/* assimp 5.2 sizes its vertex array from the header (24 GiB for 2^31 vertices; 2^27 holds
 * 1.5 GiB and loops 20 s, measured) before reading a value. */
static void test_ply_counts(void **state)
{
    const fixture_t *fx = *state;
    char path[256], text[1200], expected[700];
    snprintf(text, sizeof text, "%s%s", PLY_BOMB_HEADER, PLY_BOMB_BODY);
    assert_int_equal(strlen(text), 200);
    in_bundle(fx, "big.ply", path, sizeof path);
    testutil_write_text(path, text, 0644);
    /* After the header, the file holds the 26 bytes of PLY_BOMB_BODY. */
    snprintf(expected, sizeof expected,
             "2:17: \"%s\": PLY element \"vertex\" declares 2147483648 instances but only 26 "
             "bytes of the file are left for them (the file is truncated)",
             path);
    expect_refused(fx, "WorldBegin\nShape \"plymesh\" \"string filename\" \"big.ply\"\n", expected);

    /* The same through mesh_import_ply (a local render's unconfined parse). */
    snprintf(expected, sizeof expected,
             "\"%s\": PLY element \"vertex\" declares 2147483648 instances but only 26 bytes "
             "of the file are left for them (the file is truncated)",
             path);
    ply_job_t pj = {text, strlen(text), path};
    expect_outcome(run_in_child(job_ply_memory, &pj), "PLY 2^31 vertices", expected);

    /* A face whose ascii list length says 2^32 - 1: a reader that trusted it would size its list to that (32 GiB)
     * before reading the values; the line holds three. Line 13 is the face's. */
    const char *ascii_list =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n4294967295 0 1 2\n";
    ply_job_t aj = {ascii_list, strlen(ascii_list), "list.ply"};
    expect_outcome(run_in_child(job_ply_memory, &aj), "ascii list length",
                   "\"list.ply\": line 13 has too few values for face");

    /* The same in binary (little-endian): 3 vertices of 3 floats (36 bytes), then the face's
     * uint32 length 0xffffffff and 12 bytes of indices. */
    const char *hdr = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                      "property float y\nproperty float z\nelement face 1\n"
                      "property list uint int vertex_indices\nend_header\n";
    char bin[512];
    size_t h = strlen(hdr);
    memcpy(bin, hdr, h);
    memset(bin + h, 0, 36);
    memset(bin + h + 36, 0xff, 4);
    memset(bin + h + 40, 0, 12);
    ply_job_t bj = {bin, h + 52, "list_binary.ply"};
    expect_outcome(run_in_child(job_ply_memory, &bj), "binary list length",
                   "\"list_binary.ply\": face 0 has a list of 4294967295 values, more than the "
                   "12 bytes left (truncated)");
    /* A negative length in a signed count type would read as 2^32 - 1 unsigned. */
    const char *signed_hdr = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                             "property float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list int int vertex_indices\n"
                             "end_header\n";
    h = strlen(signed_hdr);
    memcpy(bin, signed_hdr, h);
    memset(bin + h, 0, 36);
    memset(bin + h + 36, 0xff, 4);
    memset(bin + h + 40, 0, 12);
    ply_job_t sj = {bin, h + 52, "negative.ply"};
    expect_outcome(run_in_child(job_ply_memory, &sj), "negative list length",
                   "\"negative.ply\": face 0 has a list of negative length");
    /* And the binary vertex count bomb: 2^31 vertices of 12 bytes in 52 bytes. */
    const char *count_hdr = "ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\n"
                            "property float x\nproperty float y\nproperty float z\n"
                            "element face 1\nproperty list uchar int vertex_indices\n"
                            "end_header\n";
    h = strlen(count_hdr);
    memcpy(bin, count_hdr, h);
    memset(bin + h, 0, 52);
    ply_job_t cj = {bin, h + 52, "count_binary.ply"};
    expect_outcome(run_in_child(job_ply_memory, &cj), "binary vertex count",
                   "\"count_binary.ply\": PLY element \"vertex\" declares 2147483648 instances "
                   "but only 52 bytes of the file are left for them (the file is truncated)");
    assert_int_equal(unlink(path), 0);
}

/* ---- legitimate scenes still load confined ---- */

static const scene_file_t *file_named(const scene_desc_t *d, const char *relative)
{
    for (size_t i = 0; i < d->nfiles; i++)
        if (!strcmp(d->files[i].relative, relative))
            return &d->files[i];
    fail_msg("the scene did not list %s", relative);
    return NULL;
}

static void test_legitimate_scene_loads(void **state)
{
    const fixture_t *fx = *state;
    char main_path[256], root[256];
    in_bundle(fx, "main.pbrt", main_path, sizeof main_path);
    /* The root may be written with a trailing "/." : it is normalised. */
    snprintf(root, sizeof root, "%s/.", fx->bundle);
    err_t err = {{0}};
    scene_desc_t *d = pbrt_parse_file_confined(main_path, root, NULL, &err);
    if (!d)
        fail_msg("the legitimate scene did not parse confined: %s", err.msg);
    /* main, sub/inc, sub/deeper/more, tex/t.png, meshes/tri.ply, alias.pbrt. */
    assert_int_equal(d->nfiles, 6);
    assert_int_equal(file_named(d, "sub/inc.pbrt")->kind, SCENE_FILE_INCLUDE);
    assert_int_equal(file_named(d, "sub/deeper/more.pbrt")->kind, SCENE_FILE_INCLUDE);
    assert_int_equal(file_named(d, "alias.pbrt")->kind, SCENE_FILE_INCLUDE);
    assert_int_equal(file_named(d, "meshes/tri.ply")->kind, SCENE_FILE_PLY);
    assert_int_equal(file_named(d, "tex/t.png")->kind, SCENE_FILE_IMAGE);
    for (size_t i = 1; i < d->nfiles; i++) /* files[0] is the main file */
        if (d->files[i].outside)
            fail_msg("%s (%s) is listed as outside", d->files[i].relative, d->files[i].path);
    /* In reading order: the sphere of more.pbrt, the PLY triangle, the sphere again through
     * the link. */
    assert_int_equal(d->nshapes, 3);
    assert_int_equal(d->shapes[0].type, SCENE_SHAPE_SPHERE);
    assert_int_equal(d->shapes[1].mesh.ntriangles, 1);
    assert_int_equal(d->shapes[2].type, SCENE_SHAPE_SPHERE);
    /* The image is opened later, by scene_load, through the checked real path. */
    char *real = realpath(fx->bundle, NULL);
    assert_non_null(real);
    assert_int_equal(d->ntextures, 1);
    char expected[300];
    snprintf(expected, sizeof expected, "%s/tex/t.png", real);
    assert_string_equal(d->textures[0].image.filename, expected);
    free(real);
    scene_desc_destroy(&d);

    scene_t *s = scene_load_file_confined(main_path, fx->bundle, NULL, &err);
    if (!s)
        fail_msg("the legitimate scene did not load confined: %s", err.msg);
    assert_int_equal(s->settings.xres, 8);
    scene_destroy(&s);

    /* The unconfined parse of a user's own files still reads outside the folder (the
     * client's bundler refuses such scenes before they travel). */
    in_bundle(fx, "scene.pbrt", main_path, sizeof main_path);
    testutil_write_text(main_path, "WorldBegin\nInclude \"../outside.pbrt\"\n", 0644);
    d = pbrt_parse_file(main_path, &err);
    if (!d)
        fail_msg("the unconfined parse failed: %s", err.msg);
    assert_true(file_named(d, "../outside.pbrt")->outside);
    scene_desc_destroy(&d);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_outside_and_special_files), cmocka_unit_test(test_file_size_bound),
        cmocka_unit_test(test_png_pixel_bound),           cmocka_unit_test(test_ply_counts),
        cmocka_unit_test(test_legitimate_scene_loads),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
