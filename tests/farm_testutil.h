/* farm_testutil: helpers shared by the tests that run prismfarm processes: a scratch folder
 * per test group, sleeping, and comparing two EXRs' pixel data byte for byte. Header-only (each
 * test is its own executable); include after cmocka.h. */
#ifndef PRISMFARM_FARM_TESTUTIL_H
#define PRISMFARM_FARM_TESTUTIL_H

#include "image_exr.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

/* Makes a fresh folder /tmp/prismfarm-test-NAME-XXXXXX into dir; returns 0 or -1. */
static inline int testutil_mkdtemp(char *dir, size_t size, const char *name)
{
    snprintf(dir, size, "/tmp/prismfarm-test-%s-XXXXXX", name);
    return mkdtemp(dir) ? 0 : -1;
}

/* Removes the folder and everything in it; returns 0 or -1. */
static inline int testutil_rmtree(const char *dir)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* The farm's CURVE keys for a test (docs/security.md), made with `$PRISMFARM_BIN keygen`:
 * DIR/keys/master.key and .pub, DIR/keys/farm.key and .pub (shared by the test's workers and
 * clients) and the master's authorised folder DIR/authorized holding farm.pub. PRISMFARM_KEY and
 * PRISMFARM_MASTER_KEY are then set, so every worker and client the test starts uses them;
 * master_key and authorized (size bytes each) get the master's --key and --authorized. */
static inline int testutil_farm_keys(const char *dir, char *master_key, char *authorized,
                                     size_t size)
{
    const char *bin = getenv("PRISMFARM_BIN");
    char cmd[2400], farm_key[600], master_pub[600];
    if (!bin)
        return -1;
    snprintf(cmd, sizeof cmd,
             "'%s' keygen master --dir '%s/keys' >/dev/null && '%s' keygen farm --dir '%s/keys' "
             ">/dev/null && mkdir -p '%s/authorized' && cp '%s/keys/farm.pub' '%s/authorized/'",
             bin, dir, bin, dir, dir, dir, dir);
    if (system(cmd) != 0)
        return -1;
    snprintf(master_key, size, "%s/keys/master.key", dir);
    snprintf(authorized, size, "%s/authorized", dir);
    snprintf(farm_key, sizeof farm_key, "%s/keys/farm.key", dir);
    snprintf(master_pub, sizeof master_pub, "%s/keys/master.pub", dir);
    return setenv("PRISMFARM_KEY", farm_key, 1) == 0 &&
                   setenv("PRISMFARM_MASTER_KEY", master_pub, 1) == 0
               ? 0
               : -1;
}

static inline void testutil_sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

static inline double testutil_now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Both EXRs have the same size and spectral channels and byte-identical spectral and RGB
 * pixel data. */
static inline void testutil_assert_same_pixels(const char *a, const char *b)
{
    err_t err;
    image_exr_t *x = image_exr_read(a, &err);
    if (!x)
        fail_msg("%s", err.msg);
    image_exr_t *y = image_exr_read(b, &err);
    if (!y)
        fail_msg("%s", err.msg);
    int w = image_exr_width(x), h = image_exr_height(x), n = image_exr_n_spectral(x);
    assert_int_equal(w, image_exr_width(y));
    assert_int_equal(h, image_exr_height(y));
    assert_int_equal(n, image_exr_n_spectral(y));
    assert_memory_equal(image_exr_spectral(x), image_exr_spectral(y), (size_t)w * h * n * sizeof(float));
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), (size_t)w * h * 3 * sizeof(float));
    image_exr_destroy(&x);
    image_exr_destroy(&y);
}

#endif
