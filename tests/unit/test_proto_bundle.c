/* sha256 and scene bundles: SHA-256 against the NIST example vectors (FIPS 180-4 examples,
 * "SHA256.pdf" of NIST's Cryptographic Standards and Guidelines examples), the bundle hash
 * against its documented canonical form, and extraction into a folder that must not escape it
 * through symbolic links. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers it needs */

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bundle.h"
#include "files_testutil.h"
#include "sha256.h"

static void test_sha256_nist_vectors(void **state)
{
    (void)state;
    char hex[SHA256_HEX_CHARS + 1];
    /* One-block message "abc" (NIST example B.1 of FIPS 180-2). */
    sha256_hex_of("abc", 3, hex);
    assert_string_equal(hex, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    /* The empty message. */
    sha256_hex_of("", 0, hex);
    assert_string_equal(hex, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    /* The 448-bit two-block message (example B.2): padding spills into a second block. */
    const char *m448 = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
    sha256_hex_of(m448, strlen(m448), hex);
    assert_string_equal(hex, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    /* One million 'a' (example B.3), fed in uneven pieces: the digest must not depend on the
     * split. */
    static char a[1000000];
    memset(a, 'a', sizeof a);
    sha256_t s;
    sha256_init(&s);
    size_t done = 0, step = 1;
    while (done < sizeof a) {
        size_t n = step < sizeof a - done ? step : sizeof a - done;
        sha256_update(&s, a + done, n);
        done += n;
        step = step * 3 + 1; /* 1, 4, 13, 40, ...: straddles every block boundary case */
        if (step > 70000)
            step = 7;
    }
    uint8_t d[SHA256_DIGEST_BYTES];
    sha256_final(&s, d);
    sha256_hex(d, hex);
    assert_string_equal(hex, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    /* Lengths around the padding boundary (55, 56, 63, 64 bytes) agree whole and split. */
    for (size_t n = 50; n <= 70; n++) {
        char whole[SHA256_HEX_CHARS + 1], split[SHA256_HEX_CHARS + 1];
        sha256_hex_of(a, n, whole);
        sha256_init(&s);
        sha256_update(&s, a, n / 2);
        sha256_update(&s, a + n / 2, n - n / 2);
        sha256_final(&s, d);
        sha256_hex(d, split);
        assert_string_equal(whole, split);
    }
}

static const uint8_t g_mesh[] = {1, 2, 3, 0, 255};
static const char g_scene[] = "Shape \"plymesh\" \"string filename\" \"meshes/prism.ply\"\n";
static const proto_bundle_file_t g_files[] = {
    {"scene.pbrt", (const uint8_t *)g_scene, sizeof g_scene - 1},
    {"meshes/prism.ply", g_mesh, sizeof g_mesh},
    {"textures/sub/empty.png", NULL, 0},
};
static const proto_bundle_t g_bundle = {"scene.pbrt", g_files, 3};

static void put_u64(uint8_t **p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        *(*p)++ = (uint8_t)(v >> (8 * i));
}

static void put_bytes(uint8_t **p, const void *data, size_t n)
{
    put_u64(p, n);
    memcpy(*p, data, n);
    *p += n;
}

/* The canonical form as docs/protocol.md states it, built by hand: tag, main, count, then files
 * in byte order of paths ("meshes/..." < "scene.pbrt" < "textures/..."). */
static void test_bundle_hash_is_the_documented_form(void **state)
{
    (void)state;
    static uint8_t buf[1024];
    uint8_t *p = buf;
    const char tag[] = "prismfarm bundle 1\n";
    memcpy(p, tag, sizeof tag - 1);
    p += sizeof tag - 1;
    put_bytes(&p, "scene.pbrt", 10);
    put_u64(&p, 3);
    put_bytes(&p, "meshes/prism.ply", 16);
    put_bytes(&p, g_mesh, sizeof g_mesh);
    put_bytes(&p, "scene.pbrt", 10);
    put_bytes(&p, g_scene, sizeof g_scene - 1);
    put_bytes(&p, "textures/sub/empty.png", 22);
    put_u64(&p, 0);
    char expected[SHA256_HEX_CHARS + 1], got[PROTO_HASH_HEX + 1];
    sha256_hex_of(buf, (size_t)(p - buf), expected);
    err_t err;
    assert_int_equal(proto_bundle_hash(&g_bundle, got, &err), 0);
    assert_string_equal(got, expected);

    /* The order of files does not matter; a changed byte or another main file does. */
    proto_bundle_file_t rev[3] = {g_files[2], g_files[0], g_files[1]};
    proto_bundle_t b = {"scene.pbrt", rev, 3};
    char h2[PROTO_HASH_HEX + 1];
    assert_int_equal(proto_bundle_hash(&b, h2, &err), 0);
    assert_string_equal(h2, got);
    uint8_t mesh2[sizeof g_mesh];
    memcpy(mesh2, g_mesh, sizeof mesh2);
    mesh2[4] ^= 1;
    rev[2].data = mesh2;
    assert_int_equal(proto_bundle_hash(&b, h2, &err), 0);
    assert_string_not_equal(h2, got);
    proto_bundle_t other_main = {"meshes/prism.ply", g_files, 3};
    assert_int_equal(proto_bundle_hash(&other_main, h2, &err), 0);
    assert_string_not_equal(h2, got);
    /* An invalid bundle has no hash. */
    proto_bundle_file_t bad[1] = {{"../evil", g_mesh, 1}};
    proto_bundle_t evil = {"../evil", bad, 1};
    assert_int_equal(proto_bundle_hash(&evil, h2, &err), -1);
    assert_non_null(strstr(err.msg, "'..' component"));
}

static void test_extract_writes_every_file(void **state)
{
    (void)state;
    char root[] = "/tmp/prismfarm-bundle-XXXXXX";
    assert_non_null(mkdtemp(root));
    char dir[256], path[512];
    snprintf(dir, sizeof dir, "%s/cache", root); /* created by extract */
    err_t err = {""};
    if (proto_bundle_extract(&g_bundle, dir, true, &err) != 0)
        fail_msg("%s", err.msg);
    for (size_t i = 0; i < 3; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, g_files[i].path);
        size_t n = 0;
        char *data = testutil_slurp(path, &n);
        assert_non_null(data);
        assert_int_equal(n, g_files[i].size);
        if (n)
            assert_memory_equal(data, g_files[i].data, n);
        free(data);
    }
    /* No temporary file is left behind, and extracting again (a retried job) overwrites. */
    assert_int_equal(testutil_count_entries(dir), 3); /* scene.pbrt, meshes, textures */
    assert_int_equal(proto_bundle_extract(&g_bundle, dir, true, &err), 0);
    assert_int_equal(testutil_count_entries(dir), 3);
    snprintf(path, sizeof path, "%s/meshes", dir);
    assert_int_equal(testutil_count_entries(path), 1);
    assert_int_equal(testutil_rmtree(root), 0);
}

static void test_extract_refuses_symlink_tricks(void **state)
{
    (void)state;
    char root[] = "/tmp/prismfarm-bundle-XXXXXX";
    assert_non_null(mkdtemp(root));
    char dir[256], outside[256], link[512], target[512];
    snprintf(dir, sizeof dir, "%s/cache", root);
    snprintf(outside, sizeof outside, "%s/outside", root);
    assert_int_equal(mkdir(dir, 0755), 0);
    assert_int_equal(mkdir(outside, 0755), 0);

    /* A link where a folder of the bundle goes: writing through it would land outside. */
    snprintf(link, sizeof link, "%s/meshes", dir);
    assert_int_equal(symlink(outside, link), 0);
    err_t err = {""};
    assert_int_equal(proto_bundle_extract(&g_bundle, dir, true, &err), -1);
    assert_non_null(strstr(err.msg, "'meshes' is not a plain folder"));
    assert_int_equal(testutil_count_entries(outside), 0);
    assert_int_equal(unlink(link), 0);

    /* A link where a file of the bundle goes: it is replaced, its target left untouched. */
    snprintf(target, sizeof target, "%s/precious", outside);
    FILE *f = fopen(target, "w");
    assert_non_null(f);
    fputs("keep me", f);
    assert_int_equal(fclose(f), 0);
    snprintf(link, sizeof link, "%s/scene.pbrt", dir);
    (void)unlink(link); /* the failed extraction above may have written it already */
    assert_int_equal(symlink(target, link), 0);
    assert_int_equal(proto_bundle_extract(&g_bundle, dir, true, &err), 0);
    struct stat st;
    assert_int_equal(lstat(link, &st), 0);
    assert_true(S_ISREG(st.st_mode));
    size_t n = 0;
    char *data = testutil_slurp(target, &n);
    assert_non_null(data);
    assert_int_equal(n, 7);
    assert_memory_equal(data, "keep me", 7);
    free(data);
    assert_int_equal(testutil_count_entries(outside), 1);

    /* A bundle that breaks the path rules writes nothing at all. */
    proto_bundle_file_t bad[2] = {{"ok.txt", g_mesh, 1}, {"../escape", g_mesh, 1}};
    proto_bundle_t evil = {"ok.txt", bad, 2};
    char dir2[256];
    snprintf(dir2, sizeof dir2, "%s/cache2", root);
    assert_int_equal(proto_bundle_extract(&evil, dir2, true, &err), -1);
    assert_non_null(strstr(err.msg, "'..' component"));
    assert_int_equal(access(dir2, F_OK), -1);
    snprintf(target, sizeof target, "%s/escape", root);
    assert_int_equal(access(target, F_OK), -1);
    assert_int_equal(testutil_rmtree(root), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sha256_nist_vectors),
        cmocka_unit_test(test_bundle_hash_is_the_documented_form),
        cmocka_unit_test(test_extract_writes_every_file),
        cmocka_unit_test(test_extract_refuses_symlink_tricks),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
