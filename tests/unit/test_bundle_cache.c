/* bundle_cache (worker/bundle_cache.h): a bundle is kept under its hash and refused under
 * another; its files are written without fsync, so the cache trusts them within one boot of the
 * host only: opened with the boot id it recorded, it keeps its bundles; with another (a reboot,
 * after which unsynced bytes may be lost), it empties itself and records the new one. A bundle
 * of a frame sequence holds several scene files: each loads by its name, the bundle's main by
 * default. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "bundle.h"
#include "bundle_cache.h"
#include "files_testutil.h"
#include "scene.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

static const char SCENE[] = "WorldBegin\n";

static void put_one(bundle_cache_t *c, char hash[PROTO_HASH_HEX + 1])
{
    proto_bundle_file_t f = {"scene.pbrt", (const uint8_t *)SCENE, sizeof SCENE - 1};
    proto_bundle_t b = {"scene.pbrt", &f, 1};
    err_t err;
    assert_int_equal(proto_bundle_hash(&b, hash, &err), 0);
    char wrong[PROTO_HASH_HEX + 1];
    memset(wrong, 'a', PROTO_HASH_HEX);
    wrong[PROTO_HASH_HEX] = 0;
    assert_int_equal(bundle_cache_put(c, wrong, &b, &err), -1);
    assert_non_null(strstr(err.msg, "not aaaa"));
    assert_int_equal(bundle_cache_put(c, hash, &b, &err), 0);
    assert_true(bundle_cache_has(c, hash));
}

static void test_trusted_within_one_boot(void **state)
{
    (void)state;
    char dir[600];
    snprintf(dir, sizeof dir, "%s", testutil_scratch("cache"));
    bundle_cache_t c;
    assert_int_equal(bundle_cache_open(&c, dir), 0);
    char hash[PROTO_HASH_HEX + 1];
    put_one(&c, hash);
    /* The same boot: kept. */
    bundle_cache_t again;
    assert_int_equal(bundle_cache_open(&again, dir), 0);
    assert_true(bundle_cache_has(&again, hash));
    /* Another boot's mark: emptied, and the current boot recorded. */
    char mark[700];
    snprintf(mark, sizeof mark, "%s/.boot_id", dir);
    testutil_write_text(mark, "00000000-0000-0000-0000-000000000000\n", 0644);
    bundle_cache_t rebooted;
    assert_int_equal(bundle_cache_open(&rebooted, dir), 0);
    assert_false(bundle_cache_has(&rebooted, hash));
    char *now = testutil_slurp(mark, NULL);
    char *boot = testutil_slurp("/proc/sys/kernel/random/boot_id", NULL);
    assert_non_null(now);
    assert_non_null(boot);
    assert_string_equal(now, boot);
    free(now);
    free(boot);
    /* And usable again. */
    put_one(&rebooted, hash);
}

#define FRAME(x, y)                                                                             \
    "Film \"spectral\" \"integer xresolution\" [ " #x " ] \"integer yresolution\" [ " #y " ]\n"       \
    "Camera \"perspective\"\nInclude \"world.pbrt\"\n"

static void test_frames_load_their_own_main(void **state)
{
    (void)state;
    static const char A[] = FRAME(8, 4), B[] = FRAME(6, 2), WORLD[] = "WorldBegin\n";
    proto_bundle_file_t files[3] = {{"a.pbrt", (const uint8_t *)A, sizeof A - 1},
                                    {"b.pbrt", (const uint8_t *)B, sizeof B - 1},
                                    {"world.pbrt", (const uint8_t *)WORLD, sizeof WORLD - 1}};
    proto_bundle_t b = {"a.pbrt", files, 3};
    char dir[600], hash[PROTO_HASH_HEX + 1];
    snprintf(dir, sizeof dir, "%s", testutil_scratch("frames-cache"));
    bundle_cache_t c;
    err_t err;
    assert_int_equal(bundle_cache_open(&c, dir), 0);
    assert_int_equal(proto_bundle_hash(&b, hash, &err), 0);
    assert_int_equal(bundle_cache_put(&c, hash, &b, &err), 0);
    scene_overrides_t ov = {.seed = -1};
    const char *mains[] = {NULL, "", "a.pbrt", "b.pbrt"};
    const int xres[] = {8, 8, 8, 6}, yres[] = {4, 4, 4, 2};
    for (int i = 0; i < 4; i++) {
        scene_t *sc = bundle_cache_load(&c, hash, mains[i], &ov, &err);
        if (!sc)
            fail_msg("main %s: %s", mains[i] ? mains[i] : "NULL", err.msg);
        assert_int_equal(sc->settings.xres, xres[i]);
        assert_int_equal(sc->settings.yres, yres[i]);
        scene_destroy(&sc);
    }
    assert_null(bundle_cache_load(&c, hash, "missing.pbrt", &ov, &err));
    assert_non_null(strstr(err.msg, "missing.pbrt"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_trusted_within_one_boot),
        cmocka_unit_test(test_frames_load_their_own_main),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
