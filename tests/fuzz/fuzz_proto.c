/* fuzz_proto: libFuzzer harness for the message decoder (proto/proto.h) and scene bundles
 * (proto/bundle.h), the bytes a master takes from any peer. Beyond "no crash, no leak, every
 * refusal has a message", it checks what the decoder promises:
 *  - a message it accepts, encoded again, decodes again, and that second encoding is the same
 *    bytes (encoder and decoder enforce the same rules; the encoding is canonical);
 *  - a bundle it accepts passes proto_bundle_check, hashes to the same value whatever the order
 *    of its files, and extracts into a fresh folder creating exactly its files, with their
 *    bytes, and nothing beside that folder. */
#define _XOPEN_SOURCE 700 /* opendir */

#include "bundle.h"
#include "fuzz_fixture.h"
#include "proto.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char g_base[4096];

static void cleanup(void)
{
    if (g_base[0])
        fuzz_fixture_remove(g_base);
}

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    if (fuzz_fixture_make("fuzz-proto", 0, g_base, sizeof g_base) != 0)
        abort();
    atexit(cleanup);
    return 0;
}

__attribute__((noreturn)) static void fail(const char *why, const err_t *err)
{
    fprintf(stderr, "fuzz_proto: %s%s%s\n", why, err ? ": " : "", err ? err->msg : "");
    abort();
}

/* Entries of the base folder other than "." and "..". */
static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    closedir(d);
    return n;
}

static void check_bundle(const proto_bundle_t *b, const proto_limits_t *lim)
{
    err_t err = {{0}};
    if (proto_bundle_check(b, lim, &err) != 0)
        fail("a decoded bundle fails proto_bundle_check", &err);
    char hex[PROTO_HASH_HEX + 1], hex_rev[PROTO_HASH_HEX + 1];
    if (proto_bundle_hash(b, hex, &err) != 0)
        fail("a decoded bundle does not hash", &err);
    proto_bundle_file_t *rev = malloc((b->nfiles ? b->nfiles : 1) * sizeof *rev);
    if (!rev)
        fail("out of memory", NULL);
    for (size_t i = 0; i < b->nfiles; i++)
        rev[i] = b->files[b->nfiles - 1 - i];
    proto_bundle_t rb = {b->main, rev, b->nfiles};
    if (proto_bundle_hash(&rb, hex_rev, &err) != 0 || strcmp(hex, hex_rev) != 0)
        fail("the bundle hash depends on the order of the files", NULL);
    free(rev);

    char dir[4200];
    snprintf(dir, sizeof dir, "%s/x", g_base);
    if (proto_bundle_extract(b, dir, false, &err) != 0)
        fail("a decoded bundle does not extract", &err);
    if (count_entries(g_base) != 1)
        fail("extraction created something beside its folder", NULL);
    for (size_t i = 0; i < b->nfiles; i++) {
        char path[8400];
        snprintf(path, sizeof path, "%s/%s", dir, b->files[i].path);
        size_t len;
        uint8_t *got = fuzz_fixture_read(path, &len);
        if (!got || len != b->files[i].size || (len && memcmp(got, b->files[i].data, len) != 0))
            fail("an extracted file differs from the bundle's", NULL);
        free(got);
    }
    if (fuzz_fixture_remove(dir) != 0)
        fail("cannot clean the extraction folder", NULL);
}

static const proto_bundle_t *bundle_of(const proto_msg_t *m)
{
    if (m->type == PROTO_SCENE)
        return &m->scene.bundle;
    if (m->type == PROTO_SUBMIT)
        return &m->submit.bundle;
    return NULL;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    proto_limits_t lim = proto_limits_default();
    proto_msg_t m;
    err_t err = {{0}};
    int rc = proto_decode(data, size, &lim, &m, &err);
    if (rc != 0) {
        if (rc != PROTO_EMALFORMED && rc != PROTO_EVERSION)
            fail("proto_decode returned an unknown code", NULL);
        if (!err.msg[0])
            fail("proto_decode refused without a message", NULL);
        proto_msg_free(&m);
        return 0;
    }
    msgpack_sbuffer once, twice;
    msgpack_sbuffer_init(&once);
    msgpack_sbuffer_init(&twice);
    if (proto_encode(&m, &lim, &once, &err) != 0)
        fail("a decoded message does not encode", &err);
    proto_msg_t again;
    if (proto_decode(once.data, once.size, &lim, &again, &err) != 0)
        fail("a re-encoded message does not decode", &err);
    if (again.type != m.type)
        fail("a re-encoded message decodes as another type", NULL);
    if (proto_encode(&again, &lim, &twice, &err) != 0)
        fail("a twice-decoded message does not encode", &err);
    if (once.size != twice.size || memcmp(once.data, twice.data, once.size) != 0)
        fail("the encoding is not canonical (encode(decode(encode(m))) differs)", NULL);
    const proto_bundle_t *b = bundle_of(&m);
    if (b)
        check_bundle(b, &lim);
    proto_msg_free(&again);
    proto_msg_free(&m);
    msgpack_sbuffer_destroy(&once);
    msgpack_sbuffer_destroy(&twice);
    return 0;
}
