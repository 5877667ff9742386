/* fuzz_bsdf: libFuzzer harness for the binary data files a scene names: the measured BSDF
 * reader (bsdf/measured.h over bsdf/tensor_file.h) and the NanoVDB reader (scene/nanovdb.h,
 * an input that starts with NanoVDB's magic "NanoVDB0": seeds nvdb_*: a grid of root tiles
 * only, one with a non-zero background, and OpenVDB's own ZIP-coded file of
 * tests/data/scenes/cloud_ref.nvdb). A grid read within a voxel budget of 2^20 must give
 * finite values at a few points and a majorant no less than them; one refused must say why.
 * One harness for both keeps the fuzzing time of CI (deploy/fuzz.sh) as it was. Each other
 * input is a .bsdf file's bytes. A file that is refused must say why
 * (a non-empty message); a file that is read must give finite, non-negative f and pdf and
 * samples that agree with them for a few directions. Never a crash, a leak, a read past the
 * input or an allocation beyond a small multiple of its length (-rss_limit_mb catches one). */
#include "measured.h"
#include "nanovdb.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    return 0;
}

static void check(bool ok, const char *what)
{
    if (!ok) {
        fprintf(stderr, "fuzz_bsdf: %s\n", what);
        abort();
    }
}

static int fuzz_nanovdb(const uint8_t *data, size_t size)
{
    err_t err = {{0}};
    nanovdb_grid_t *g = NULL;
    uint64_t voxels = 0;
    if (nanovdb_read(data, size, "density", (uint64_t)1 << 20, &g, &voxels, &err) != 0) {
        check(memchr(err.msg, 0, sizeof err.msg) && err.msg[0],
              "nanovdb refused without a message");
        check(g == NULL, "a refused grid was returned");
        return 0;
    }
    check(voxels <= (uint64_t)1 << 20, "the grid took more than its voxel budget");
    if (!g)
        return 0;
    vec3_t lo, hi;
    nanovdb_bounds(g, &lo, &hi);
    transform_t to_index = nanovdb_medium_to_index(g);
    for (int i = 0; i < 8; i++) {
        vec3_t p = vec3_make(i & 1 ? hi.x : lo.x + 0.3 * (hi.x - lo.x), i & 2 ? hi.y : lo.y,
                             i & 4 ? hi.z : lo.z);
        double v = nanovdb_sample(g, p);
        check(isfinite(v), "a sample is not finite");
        vec3_t q = transform_point(&to_index, p);
        if (fabs(q.x) < 1e9 && fabs(q.y) < 1e9 && fabs(q.z) < 1e9) {
            int64_t a[3] = {(int64_t)floor(q.x), (int64_t)floor(q.y), (int64_t)floor(q.z)};
            int64_t b[3] = {a[0] + 1, a[1] + 1, a[2] + 1};
            check(nanovdb_max_in(g, a, b) >= v - 1e-6 * fabs(v), "the maximum is below a sample");
        }
    }
    nanovdb_destroy(&g);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size >= 8 && !memcmp(data, "NanoVDB0", 8))
        return fuzz_nanovdb(data, size);
    err_t err = {{0}};
    measured_t *m = measured_new(data, size, "input.bsdf", &err);
    if (!m) {
        check(memchr(err.msg, 0, sizeof err.msg) && err.msg[0], "refused without a message");
        return 0;
    }
    const double lambda[3] = {300.0, 550.0, 900.0};
    const vec3_t dirs[4] = {{0, 0, 1}, {0.6, 0, 0.8}, {-0.3, 0.9, 0.3162278}, {0.99, 0.1, 0.0995}};
    for (int i = 0; i < 4; i++) {
        for (int j = 0; j < 4; j++) {
            double f[3];
            measured_eval(m, dirs[i], dirs[j], lambda, 3, f);
            double p = measured_pdf(m, dirs[i], dirs[j]);
            check(isfinite(p) && p >= 0.0, "pdf not finite or negative");
            for (int k = 0; k < 3; k++)
                check(isfinite(f[k]) && f[k] >= 0.0, "f not finite or negative");
        }
        vec3_t wi;
        double f[3], pdf;
        if (measured_sample(m, dirs[i], 0.37, 0.61, lambda, 3, &wi, f, &pdf))
            check(isfinite(pdf) && pdf > 0.0 && wi.z > 0.0 && isfinite(f[0]), "bad sample");
    }
    measured_destroy(&m);
    return 0;
}
