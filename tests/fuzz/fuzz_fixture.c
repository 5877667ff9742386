#define _XOPEN_SOURCE 700 /* mkdtemp, nftw */

#include "fuzz_fixture.h"

#include <errno.h>
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char INCLUDE_TEXT[] = "# included by fuzzed scenes\n"
                                   "AttributeBegin\n"
                                   "  Material \"diffuse\" \"rgb reflectance\" [0.5 0.4 0.3]\n"
                                   "  Shape \"sphere\" \"float radius\" 0.25\n"
                                   "AttributeEnd\n";

/* Resolved against its own folder: reaches the top-level include through "..", which stays
 * inside the scene's folder. */
static const char SUB_INCLUDE_TEXT[] = "Translate 0 1 0\n"
                                       "Include \"../inc.pbrt\"\n";

/* A unit quad with (u, v) and one triangle: 3 triangles after the quad is split. */
static const char PLY_ASCII[] = "ply\n"
                                "format ascii 1.0\n"
                                "element vertex 5\n"
                                "property float x\nproperty float y\nproperty float z\n"
                                "property float u\nproperty float v\n"
                                "element face 2\n"
                                "property list uchar int vertex_indices\n"
                                "end_header\n"
                                "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n0.5 0.5 1 0.5 0.5\n"
                                "4 0 1 2 3\n3 0 1 4\n";

static const char PLY_BINARY_HEADER[] = "ply\n"
                                        "format binary_little_endian 1.0\n"
                                        "element vertex 4\n"
                                        "property float x\nproperty float y\nproperty float z\n"
                                        "property float nx\nproperty float ny\nproperty float nz\n"
                                        "element face 4\n"
                                        "property list uchar int vertex_indices\n"
                                        "end_header\n";

/* The 2x2 8-bit grey checker of tests/data/scene_checker2x2.png (255 0 / 0 255), byte for byte
 * as tests/data/scenes/meshes/make_meshes.py writes it. */
static const uint8_t PNG_CHECKER[] = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44,
    0x52, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x08, 0x00, 0x00, 0x00, 0x00, 0x57,
    0xdd, 0x52, 0xf8, 0x00, 0x00, 0x00, 0x0e, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8,
    0xcf, 0xc0, 0xc0, 0xf0, 0x1f, 0x00, 0x06, 0x00, 0x01, 0xff, 0x78, 0x5c, 0xb6, 0x81, 0x00,
    0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

static size_t put_le32(uint8_t *out, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        out[i] = (uint8_t)(v >> (8 * i));
    return 4;
}

static size_t put_float(uint8_t *out, float f)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    return put_le32(out, bits);
}

/* The unit tetrahedron, binary little-endian, normals (0 0 1), outward-wound faces. */
static size_t ply_binary(uint8_t *out)
{
    static const float V[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    static const uint32_t F[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    size_t n = strlen(PLY_BINARY_HEADER);
    memcpy(out, PLY_BINARY_HEADER, n);
    for (int v = 0; v < 4; v++) {
        for (int k = 0; k < 3; k++)
            n += put_float(out + n, V[v][k]);
        n += put_float(out + n, 0.0f);
        n += put_float(out + n, 0.0f);
        n += put_float(out + n, 1.0f);
    }
    for (int f = 0; f < 4; f++) {
        out[n++] = 3;
        for (int k = 0; k < 3; k++)
            n += put_le32(out + n, F[f][k]);
    }
    return n;
}

int fuzz_fixture_write(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f) {
        fprintf(stderr, "fuzz_fixture: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    size_t w = n ? fwrite(data, 1, n, f) : 0;
    if (fclose(f) != 0 || w != n) {
        fprintf(stderr, "fuzz_fixture: cannot write %s\n", path);
        return -1;
    }
    return 0;
}

uint8_t *fuzz_fixture_read(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "fuzz_fixture: cannot open %s: %s\n", path, strerror(errno));
        return NULL;
    }
    size_t cap = 4096, n = 0;
    uint8_t *buf = malloc(cap + 1);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        uint8_t *nb = realloc(buf, 2 * cap + 1);
        if (!nb)
            free(buf);
        buf = nb;
        cap *= 2;
    }
    int bad = ferror(f);
    fclose(f);
    if (!buf || bad) {
        free(buf);
        fprintf(stderr, "fuzz_fixture: cannot read %s\n", path);
        return NULL;
    }
    buf[n] = 0;
    *len = n;
    return buf;
}

static int write_in(const char *dir, const char *name, const void *data, size_t n)
{
    char path[4096];
    int w = snprintf(path, sizeof path, "%s/%s", dir, name);
    if (w < 0 || (size_t)w >= sizeof path)
        return -1;
    return fuzz_fixture_write(path, data, n);
}

int fuzz_fixture_make(const char *prefix, int with_files, char *dir, size_t dir_size)
{
    const char *tmp = getenv("TMPDIR");
    if (!tmp || !*tmp)
        tmp = "/tmp";
    int w = snprintf(dir, dir_size, "%s/prismfarm-%s-XXXXXX", tmp, prefix);
    if (w < 0 || (size_t)w >= dir_size || !mkdtemp(dir)) {
        fprintf(stderr, "fuzz_fixture: cannot make a folder in %s: %s\n", tmp, strerror(errno));
        return -1;
    }
    if (!with_files)
        return 0;
    char sub[4096];
    snprintf(sub, sizeof sub, "%s/sub", dir);
    uint8_t ply[1024];
    size_t nply = ply_binary(ply);
    if (mkdir(sub, 0700) != 0 ||
        write_in(dir, FUZZ_FIXTURE_INCLUDE, INCLUDE_TEXT, strlen(INCLUDE_TEXT)) != 0 ||
        write_in(dir, FUZZ_FIXTURE_SUB_INCLUDE, SUB_INCLUDE_TEXT, strlen(SUB_INCLUDE_TEXT)) != 0 ||
        write_in(dir, FUZZ_FIXTURE_PLY_ASCII, PLY_ASCII, strlen(PLY_ASCII)) != 0 ||
        write_in(dir, FUZZ_FIXTURE_PLY_BINARY, ply, nply) != 0 ||
        write_in(dir, FUZZ_FIXTURE_PNG, PNG_CHECKER, sizeof PNG_CHECKER) != 0) {
        fprintf(stderr, "fuzz_fixture: cannot fill %s\n", dir);
        fuzz_fixture_remove(dir);
        return -1;
    }
    return 0;
}

static int remove_one(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st;
    (void)ftw;
    int rc = flag == FTW_DP ? rmdir(path) : unlink(path);
    if (rc != 0)
        fprintf(stderr, "fuzz_fixture: cannot remove %s: %s\n", path, strerror(errno));
    return rc;
}

int fuzz_fixture_remove(const char *dir)
{
    return nftw(dir, remove_one, 16, FTW_DEPTH | FTW_PHYS) == 0 ? 0 : -1;
}
