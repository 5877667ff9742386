/* fuzz_bsdf: libFuzzer harness for the measured BSDF reader (bsdf/measured.h over
 * bsdf/tensor_file.h): each input is a .bsdf file's bytes. A file that is refused must say why
 * (a non-empty message); a file that is read must give finite, non-negative f and pdf and
 * samples that agree with them for a few directions. Never a crash, a leak, a read past the
 * input or an allocation beyond a small multiple of its length (-rss_limit_mb catches one). */
#include "measured.h"

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

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
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
