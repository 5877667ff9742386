/* CURVE on the farm (docs/security.md). `prismfarm keygen` writes Z85 key files with the
 * right modes, checked against libzmq's own zmq_curve_public and the key pair published in
 * zmq_curve(7); malformed key files are refused naming file and line. A master with keys lets in
 * an authorised worker and client (a job completes with the pixels of `prismfarm render`),
 * refuses at once and says so to an unauthorised client, a plain-text client and a client holding
 * the wrong master key, logs refusals with the peer's address, and picks up a .pub added to (or
 * removed from) its folder without a restart. A tcp:// master without keys refuses to start
 * unless --insecure, which runs a plain-text farm; ipc:// needs neither. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 60000
#include "cli_run.h"
#include "curve.h"
#include "farm_testutil.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <zmq.h>

/* The Z85 alphabet as ZeroMQ RFC 32 lists it, typed here rather than taken from the code. */
static const char RFC32_Z85[] =
    "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ.-:+=^!/*?&<>()[]{}@%$#";

/* The example server key pair of zmq_curve(7) ("EXAMPLE"), and its client public key. */
#define DOC_SERVER_PUBLIC "rq:rM>}U?@Lns47E1%kR.o@n%FcmmsL/@{H8]yf7"
#define DOC_SERVER_SECRET "JTKVSB%%)wK0E.X)V>+}o?pNmC{O&4W4b!Ni{Lh6"
#define DOC_CLIENT_PUBLIC "Yne@$w-vo<fVvi]a<NY6T1ed:M$fCG*[IaLV{hID"

static char FARM_KEY[600], MASTER_PUB[600]; /* what PRISMFARM_KEY, _MASTER_KEY hold */

static int group_setup(void **state)
{
    if (testutil_scratch_keys_setup(state) < 0)
        return -1;
    snprintf(FARM_KEY, sizeof FARM_KEY, "%s", getenv("PRISMFARM_KEY"));
    snprintf(MASTER_PUB, sizeof MASTER_PUB, "%s", getenv("PRISMFARM_MASTER_KEY"));
    return 0;
}

/* The keys in the environment on (the farm's) or off (none), for the children started next. */
static void env_keys(int on)
{
    if (on) {
        assert_int_equal(setenv("PRISMFARM_KEY", FARM_KEY, 1), 0);
        assert_int_equal(setenv("PRISMFARM_MASTER_KEY", MASTER_PUB, 1), 0);
    } else {
        assert_int_equal(unsetenv("PRISMFARM_KEY"), 0);
        assert_int_equal(unsetenv("PRISMFARM_MASTER_KEY"), 0);
    }
}

/* The value of the "NAME = " line of a key file (40 characters), into out[41]. */
static void key_line(const char *text, const char *name, char out[41])
{
    char key[32];
    snprintf(key, sizeof key, "\n%s = ", name);
    const char *p = strstr(text, key);
    if (!p)
        fail_msg("no '%s = ' line in:\n%s", name, text);
    p += strlen(key);
    size_t n = strcspn(p, "\n");
    assert_int_equal(n, 40);
    assert_int_equal(strspn(p, RFC32_Z85), 40);
    memcpy(out, p, 40);
    out[40] = 0;
}

/* key_line of the key file at path. */
static void key_file_line(const char *path, const char *name, char out[41])
{
    char *text = testutil_slurp(path, NULL);
    if (!text)
        fail_msg("cannot read %s", path);
    key_line(text, name, out);
    free(text);
}

static int mode_of(const char *path)
{
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return (int)(st.st_mode & 0777);
}

/* keygen's files: modes 0600 and 0644 (and 0600 for the dashboard token, whose hash alone the
 * .pub carries), a comment header, Z85 keys, a public key that libzmq
 * derives from the secret one; no overwrite without --force; names that are paths refused. */
static void test_keygen_files(void **state)
{
    (void)state;
    const char *dir = testutil_scratch("kg");
    const run_t *r = run("keygen", "alice", "--dir", dir, NULL);
    if (r->status != 0)
        fail_msg("keygen: exit %d: %s", r->status, r->err);
    char key[700], pub[700];
    snprintf(key, sizeof key, "%s/alice.key", dir);
    snprintf(pub, sizeof pub, "%s/alice.pub", dir);
    expect_in(r->out, key);
    expect_in(r->out, pub);
    assert_int_equal(mode_of(key), 0600);
    assert_int_equal(mode_of(pub), 0644);
    assert_int_equal(mode_of(dir), 0700);

    char *key_text = testutil_slurp(key, NULL), *pub_text = testutil_slurp(pub, NULL);
    assert_true(key_text && pub_text && key_text[0] == '#' && pub_text[0] == '#');
    char public1[41], secret[41], public2[41], derived[41];
    key_line(key_text, "public-key", public1);
    key_line(key_text, "secret-key", secret);
    key_line(pub_text, "public-key", public2);
    assert_string_equal(public1, public2);
    assert_null(strstr(pub_text, "secret"));
    assert_int_equal(zmq_curve_public(derived, secret), 0);
    assert_string_equal(derived, public1);
    /* The dashboard token (docs/dashboard.md): mode 0600 from the start, and only its SHA-256
     * in the .pub, which the ring finds the key's name by. */
    char token_path[700];
    snprintf(token_path, sizeof token_path, "%s/alice.token", dir);
    expect_in(r->out, token_path);
    assert_int_equal(mode_of(token_path), 0600);
    uint8_t token_hash[CURVE_TOKEN_HASH];
    err_t terr;
    assert_int_equal(curve_load_token(token_path, token_hash, &terr), 0);
    char *token_text = testutil_slurp(token_path, NULL);
    const char *token = strrchr(token_text, '\n');
    while (token > token_text && token[-1] != '\n')
        token--; /* the last line: the token itself */
    char first16[17];
    snprintf(first16, sizeof first16, "%.16s", token);
    assert_null(strstr(pub_text, first16));
    expect_in(pub_text, "http-token-sha256 = ");
    curve_ring_t *ring = curve_ring_new(dir, &terr);
    assert_non_null(ring);
    assert_string_equal(curve_ring_find_token(ring, token_hash), "alice");
    token_hash[0] ^= 1;
    assert_null(curve_ring_find_token(ring, token_hash));
    curve_ring_destroy(&ring);
    free(token_text);

    /* Not overwritten: exit 1, the files as they were. */
    r = run("keygen", "alice", "--dir", dir, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "exists: not overwritten");
    char *key_now = testutil_slurp(key, NULL), *pub_now = testutil_slurp(pub, NULL);
    assert_true(key_now && pub_now);
    assert_string_equal(key_now, key_text);
    assert_string_equal(pub_now, pub_text);
    free(key_now);
    free(pub_now);
    free(key_text);
    free(pub_text);
    r = run("keygen", "alice", "--dir", dir, "--force", NULL);
    assert_int_equal(r->status, 0);
    char public3[41];
    key_file_line(pub, "public-key", public3);
    assert_string_not_equal(public3, public1);
    assert_int_equal(mode_of(key), 0600);

    /* A second name, a second key: 2^-256 odds of a repeat. */
    r = run("keygen", "bob", "--dir", dir, NULL);
    assert_int_equal(r->status, 0);
    char bob[41];
    snprintf(pub, sizeof pub, "%s/bob.pub", dir);
    key_file_line(pub, "public-key", bob);
    assert_string_not_equal(bob, public3);

    static const char *const bad[] = {
        "../evil", "a/b", "",
        ".hidden", "-x",  "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        r = run("keygen", bad[i], "--dir", dir, NULL);
        if (r->status != 2)
            fail_msg("keygen '%s': exit %d, expected 2: %s", bad[i], r->status, r->err);
    }
    struct stat st;
    assert_int_not_equal(stat(testutil_scratch("evil.key"), &st), 0);
}

/* Key files read by hand-written examples: the zmq_curve(7) pair loads (with comments, blank
 * lines, CRLF and spaces around '='); every malformed file is refused naming file, line and what
 * was expected. */
static void test_key_file_errors(void **state)
{
    (void)state;
    err_t err;
    curve_pair_t pair;
    char pub[41];
    const char *p = testutil_scratch("doc.key");
    testutil_write_text(p,
                        "# the example of zmq_curve(7)\r\n\r\n  public-key=" DOC_SERVER_PUBLIC
                        "\r\nsecret-key =   " DOC_SERVER_SECRET "  \r\n",
                        0600);
    if (curve_load_pair(p, &pair, &err) < 0)
        fail_msg("%s", err.msg);
    assert_string_equal(pair.public_key, DOC_SERVER_PUBLIC);
    assert_string_equal(pair.secret_key, DOC_SERVER_SECRET);

    /* Others may read it: refused like ssh refuses such a key. */
    assert_int_equal(chmod(p, 0644), 0);
    assert_int_equal(curve_load_pair(p, &pair, &err), -1);
    expect_in(err.msg, "chmod 600");
    expect_in(err.msg, p);

    static const struct {
        const char *text;
        const char *message;
    } bad[] = {
        {"# x\npublic-key = " DOC_SERVER_PUBLIC "\nhello\n", ":3: expected 'public-key = KEY'"},
        {"public-key = rq:rM>}U?@Lns47E1%kR.o@n%FcmmsL/@{H8]yf\n", ":1: public-key has 39 "
                                                                   "characters, expected 40"},
        {"public-key = rq:rM>}U?@Lns47E1%kR.o@n%FcmmsL/@{H8]y\"7\n", ":1: public-key has a "
                                                                     "character that is not Z85 "
                                                                     "at column 39"},
        {"public-key = " DOC_CLIENT_PUBLIC "\nsecret-key = " DOC_SERVER_SECRET "\n",
         ":1: public-key is not the public half of secret-key (line 2)"},
        {"public-key = " DOC_SERVER_PUBLIC "\n", "no 'secret-key = ...' line"},
        {"public-key = " DOC_SERVER_PUBLIC "\npublic-key = " DOC_SERVER_PUBLIC "\n",
         ":2: a second public-key (the first is on line 1)"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        testutil_write_text(p, bad[i].text, 0600);
        if (curve_load_pair(p, &pair, &err) == 0)
            fail_msg("case %zu loaded", i);
        char want[700];
        snprintf(want, sizeof want, "%s%s", bad[i].message[0] == ':' ? p : "", bad[i].message);
        expect_in(err.msg, want);
    }
    /* A secret key where a public one is expected: the file must not travel. */
    testutil_write_text(
        p, "public-key = " DOC_SERVER_PUBLIC "\nsecret-key = " DOC_SERVER_SECRET "\n", 0600);
    assert_int_equal(curve_load_public(p, pub, &err), -1);
    expect_in(err.msg, ":2: a secret key");
    assert_int_equal(curve_load_public(testutil_scratch("none.pub"), pub, &err), -1);
    expect_in(err.msg, "none.pub: cannot open");
    /* A .pub that is fine, and an authorised folder that holds a bad one. */
    testutil_write_text(testutil_scratch("doc.pub"), "public-key = " DOC_CLIENT_PUBLIC "\n", 0644);
    assert_int_equal(curve_load_public(testutil_scratch("doc.pub"), pub, &err), 0);
    assert_string_equal(pub, DOC_CLIENT_PUBLIC);
    const char *ring = testutil_scratch("ring");
    assert_int_equal(mkdir(ring, 0700), 0);
    testutil_write_text(testutil_scratch("ring/ok.pub"), "public-key = " DOC_CLIENT_PUBLIC "\n",
                        0644);
    testutil_write_text(testutil_scratch("ring/README"), "not a key, not a .pub: ignored\n", 0644);
    curve_ring_t *keys = curve_ring_new(ring, &err);
    assert_non_null(keys);
    assert_int_equal(curve_ring_size(keys), 1);
    uint8_t bin[32];
    assert_non_null(zmq_z85_decode(bin, DOC_CLIENT_PUBLIC));
    assert_string_equal(curve_ring_find(keys, bin), "ok");
    assert_non_null(zmq_z85_decode(bin, DOC_SERVER_PUBLIC));
    assert_null(curve_ring_find(keys, bin));
    curve_ring_destroy(&keys);
    testutil_write_text(testutil_scratch("ring/bad.pub"), "public-key = short\n", 0644);
    assert_null(curve_ring_new(ring, &err));
    expect_in(err.msg, "ring/bad.pub:1: public-key has 5 characters");
}

/* A farm with keys: an authorised worker and client complete a job; an unauthorised client, a
 * plain-text client and one with the wrong master key are told why at once; refusals are
 * logged with the address; a .pub added to the folder is let in, and out again once removed. */
static void test_farm_with_keys(void **state)
{
    (void)state;
    env_keys(1);
    const char *spool = testutil_scratch("spool"), *mlog = testutil_scratch("master.log");
    pid_t master = testutil_start_master(mlog, spool, "tcp://127.0.0.1:*", "tcp://127.0.0.1:*",
                                         "--heartbeat", "200", "--tile", "8", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog);
    pid_t worker =
        testutil_start_worker(testutil_scratch("w1.log"), wep, "w1", testutil_scratch("c1"));
    const run_t *r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "4", "--wait",
                         "-o", testutil_scratch("farm.exr"), "--quiet", NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "submit --wait: exit %d: %s\nmaster log:", r->status, r->err);
    r = run("render", "data/render/tiny.pbrt", "--spp", "4", "-o", testutil_scratch("render.exr"),
            "--quiet", NULL);
    assert_int_equal(r->status, 0);
    testutil_assert_same_pixels(testutil_scratch("farm.exr"), testutil_scratch("render.exr"));
    testutil_expect_file_has(mlog, "accepted key 'farm' on the workers endpoint from 127.0.0.1");
    testutil_expect_file_has(mlog, "accepted key 'farm' on the clients endpoint from 127.0.0.1");

    /* A stranger's key: refused by the handshake, reported at once -- well before the 60 s
     * answer timeout the client is given, which it would otherwise wait out -- and logged by
     * the master with its address and key. */
    r = run("keygen", "intruder", "--dir", testutil_scratch("keys"), NULL);
    assert_int_equal(r->status, 0);
    char intruder_key[700], intruder_pub[700], intruder[41];
    snprintf(intruder_key, sizeof intruder_key, "%s", testutil_scratch("keys/intruder.key"));
    snprintf(intruder_pub, sizeof intruder_pub, "%s", testutil_scratch("keys/intruder.pub"));
    key_file_line(intruder_pub, "public-key", intruder);
    double t0 = testutil_now_s();
    r = run("jobs", "--master", cep, "--key", intruder_key, "--timeout", "60", NULL);
    double took = testutil_now_s() - t0;
    assert_int_equal(r->status, 1);
    expect_in(r->err, "refused our key (ZAP status 400)");
    print_message("refused client told in %.2f s\n", took);
    assert_true(took < 30.0);
    char line[300];
    snprintf(line, sizeof line,
             "refused a connection to the clients endpoint from 127.0.0.1: key %s", intruder);
    testutil_wait_file_has(mlog, line);

    /* A worker with that key never joins; the refusal is logged for the workers endpoint. */
    pid_t stranger = testutil_spawn(testutil_scratch("w2.log"), "worker", "--connect", wep,
                                    "--threads", "1", "--name", "stranger", "--key", intruder_key,
                                    "--cache", testutil_scratch("c2"), NULL);
    snprintf(line, sizeof line,
             "refused a connection to the workers endpoint from 127.0.0.1: key %s", intruder);
    testutil_wait_file_has(mlog, line);
    r = run("workers", "--master", cep, "--json", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"w1\"");
    assert_null(strstr(r->out, "stranger"));
    testutil_stop(stranger, SIGTERM);

    /* No keys over tcp: the client refuses to send plain text unless told to. */
    env_keys(0);
    r = run("jobs", "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "--key FILE and --master-key FILE.pub");
    expect_in(r->err, "--insecure");
    /* Told to: the master's CURVE handshake refuses it. */
    r = run("jobs", "--master", cep, "--insecure", NULL);
    assert_int_equal(r->status, 1);
    if (!strstr(r->err, "requires CURVE") && !strstr(r->err, "may require CURVE keys"))
        fail_msg("a plain client was not told that the master requires CURVE: %s", r->err);
    /* Our key, but another master's public key: the handshake cannot succeed. */
    r = run("jobs", "--master", cep, "--key", FARM_KEY, "--master-key", intruder_pub, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "is --master-key its public key");
    /* Half the keys. */
    r = run("jobs", "--master", cep, "--key", FARM_KEY, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "--key needs --master-key");

    /* Authorised while the master runs: its folder is read again. */
    char cmd[1600];
    snprintf(cmd, sizeof cmd, "cp '%s' '%s/'", intruder_pub, testutil_authorized());
    assert_int_equal(system(cmd), 0);
    r = run("jobs", "--master", cep, "--key", intruder_key, "--master-key", MASTER_PUB, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog,
                              "a key added to the folder was not let in: %s\nmaster log:", r->err);
    expect_in(r->out, "tiny");
    char added[700];
    snprintf(added, sizeof added, "%s/intruder.pub", testutil_authorized());
    assert_int_equal(unlink(added), 0);
    r = run("jobs", "--master", cep, "--key", intruder_key, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "refused our key");
    testutil_stop(worker, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* Roles (issue 16, item 2): with --authorized-workers and --authorized-clients a client's key is
 * refused on the workers endpoint (it used to join as a worker and could return any task's
 * pixels) and a worker's on the clients endpoint, each logged with the key's name and role;
 * each key works where it belongs. */
static void test_roles(void **state)
{
    (void)state;
    env_keys(0);
    char cmd[2400];
    const char *k = testutil_scratch("rolekeys");
    const char *aw = testutil_scratch("auth-workers"), *ac = testutil_scratch("auth-clients");
    snprintf(cmd, sizeof cmd,
             "'%s' keygen render1 --dir '%s' >/dev/null && '%s' keygen alice --dir '%s' "
             ">/dev/null && mkdir -p '%s' '%s' && cp '%s/render1.pub' '%s/' && "
             "cp '%s/alice.pub' '%s/'",
             getenv("PRISMFARM_BIN"), k, getenv("PRISMFARM_BIN"), k, aw, ac, k, aw, k, ac);
    assert_int_equal(system(cmd), 0);
    char render1[700], alice[700];
    snprintf(render1, sizeof render1, "%s/render1.key", k);
    snprintf(alice, sizeof alice, "%s/alice.key", k);
    const char *spool = testutil_scratch("role-spool"), *mlog = testutil_scratch("role-master.log");
    pid_t master = testutil_spawn(mlog, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                                  "tcp://127.0.0.1:*", "--spool", spool, "--key",
                                  testutil_master_key(), "--authorized-workers", aw,
                                  "--authorized-clients", ac, "--heartbeat", "200", "--tile", "8",
                                  NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog);
    /* A client's key on the workers endpoint: never joins, logged with its name and role. */
    pid_t sneaky = testutil_spawn(testutil_scratch("sneaky.log"), "worker", "--connect", wep,
                                  "--threads", "1", "--name", "sneaky", "--key", alice,
                                  "--master-key", MASTER_PUB, "--cache", testutil_scratch("c3"),
                                  NULL);
    testutil_wait_file_has(mlog, "refused a connection to the workers endpoint from 127.0.0.1: "
                                 "key 'alice' is a client key");
    pid_t worker = testutil_spawn(testutil_scratch("render1.log"), "worker", "--connect", wep,
                                  "--threads", "1", "--name", "render1", "--key", render1,
                                  "--master-key", MASTER_PUB, "--cache", testutil_scratch("c4"),
                                  NULL);
    const run_t *r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "4",
                         "--wait", "-o", testutil_scratch("role.exr"), "--quiet", "--key", alice,
                         "--master-key", MASTER_PUB, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "submit --wait: exit %d: %s\nmaster log:", r->status, r->err);
    testutil_expect_file_has(mlog, "accepted key 'render1' on the workers endpoint");
    testutil_expect_file_has(mlog, "accepted key 'alice' on the clients endpoint");
    r = run("workers", "--master", cep, "--json", "--key", alice, "--master-key", MASTER_PUB,
            NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"render1\"");
    assert_null(strstr(r->out, "sneaky"));
    /* A worker's key on the clients endpoint: refused. */
    r = run("jobs", "--master", cep, "--key", render1, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "refused our key");
    testutil_wait_file_has(mlog, "refused a connection to the clients endpoint from 127.0.0.1: "
                                 "key 'render1' is a worker key");
    /* Both ways of authorising at once is a bad command line. */
    r = run("master", "--workers", "tcp://127.0.0.1:*", "--clients", "tcp://127.0.0.1:*",
            "--spool", testutil_scratch("role-spool2"), "--key", testutil_master_key(),
            "--authorized", ac, "--authorized-workers", aw, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "not both");
    testutil_stop(sneaky, SIGTERM);
    testutil_stop(worker, SIGTERM);
    testutil_stop(master, SIGTERM);
    env_keys(1);
}

/* Owners (issue 16, item 11): a job belongs to the key that submitted it. Another client key
 * may list it (with its owner) but not fetch, cancel or refine it; an admin key may; every
 * action and every refusal is logged with the key's name; the owner survives a restart. */
static void test_owners(void **state)
{
    (void)state;
    env_keys(0);
    char cmd[4000];
    const char *bin = getenv("PRISMFARM_BIN");
    const char *k = testutil_scratch("ownerkeys"), *aw = testutil_scratch("own-workers"),
               *ac = testutil_scratch("own-clients"), *aa = testutil_scratch("own-admins");
    snprintf(cmd, sizeof cmd,
             "set -e; for n in render1 alice bob carol; do '%s' keygen $n --dir '%s' >/dev/null; "
             "done; mkdir -p '%s' '%s' '%s'; cp '%s/render1.pub' '%s/'; cp '%s/alice.pub' "
             "'%s/bob.pub' '%s/'; cp '%s/carol.pub' '%s/'",
             bin, k, aw, ac, aa, k, aw, k, k, ac, k, aa);
    assert_int_equal(system(cmd), 0);
    char key[4][700];
    const char *names[4] = {"render1", "alice", "bob", "carol"};
    for (int i = 0; i < 4; i++)
        snprintf(key[i], sizeof key[i], "%s/%s.key", k, names[i]);
    const char *alice = key[1], *bob = key[2], *carol = key[3];
    const char *spool = testutil_scratch("own-spool");
    char mlog[700];
    snprintf(mlog, sizeof mlog, "%s", testutil_scratch("own-master.log"));
    pid_t master = testutil_spawn(mlog, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                                  "tcp://127.0.0.1:*", "--spool", spool, "--key",
                                  testutil_master_key(), "--authorized-workers", aw,
                                  "--authorized-clients", ac, "--authorized-admins", aa,
                                  "--heartbeat", "200", "--tile", "8", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog);
    /* Job 1 by alice, with no worker yet: it stays queued while the others try it. */
    const run_t *r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "4",
                         "--quiet", "--key", alice, "--master-key", MASTER_PUB, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "submit: exit %d: %s\nmaster log:", r->status, r->err);
    r = run("jobs", "--master", cep, "--json", "--key", bob, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"owner\": \"alice\"");
    r = run("cancel", "1", "--master", cep, "--key", bob, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "job 1 belongs to 'alice': only its owner or an admin");
    r = run("fetch", "1", "-o", testutil_scratch("bob.exr"), "--master", cep, "--key", bob,
            "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "job 1 belongs to 'alice'");
    testutil_wait_file_has(mlog, "(key 'bob'): refused to cancel job 1: it belongs to 'alice'");
    testutil_wait_file_has(mlog, "(key 'bob'): refused to fetch job 1: it belongs to 'alice'");
    /* The operations follow the same rule (docs/farm.md, "Operating a farm"), and log the key. */
    r = run("pause", "1", "--master", cep, "--key", bob, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "pause: job 1 belongs to 'alice'");
    r = run("logs", "1", "--master", cep, "--key", bob, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "job 1 belongs to 'alice'");
    r = run("priority", "1", "5", "--master", cep, "--json", "--key", alice, "--master-key",
            MASTER_PUB, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "priority: exit %d: %s\nmaster log:", r->status, r->err);
    expect_in(r->out, "\"priority\": 5");
    r = run("pause", "1", "--master", cep, "--json", "--key", alice, "--master-key", MASTER_PUB,
            NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"paused\"");
    r = run("resume", "1", "--master", cep, "--key", alice, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 0);
    r = run("logs", "1", "--master", cep, "--key", alice, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "job priority 0 -> 5 by alice");
    expect_in(r->out, "job paused by alice");
    expect_in(r->out, "job resumed by alice");
    r = run("unblock", "render1", "--master", cep, "--key", alice, "--master-key", MASTER_PUB,
            NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "only an admin may unblock a worker");
    r = run("unblock", "render1", "--master", cep, "--key", carol, "--master-key", MASTER_PUB,
            NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "worker 'render1' is not blocked");
    r = run("metrics", "--master", cep, "--key", bob, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "prismfarm_jobs{state=\"queued\"} 1\n");
    testutil_wait_file_has(mlog, "pause of job 1 by bob refused");
    testutil_wait_file_has(mlog, "job 1 priority 0 -> 5 by alice");
    /* The job is untouched by the refusals; an admin may cancel it. */
    r = run("jobs", "--master", cep, "--json", "--key", alice, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"queued\"");
    r = run("cancel", "1", "--master", cep, "--key", carol, "--master-key", MASTER_PUB, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "admin cancel: exit %d: %s\nmaster log:", r->status, r->err);
    testutil_wait_file_has(mlog, "(key 'carol') [admin]: cancelled job 1");

    /* Job 2 by alice renders; she fetches it, bob may not. */
    pid_t worker = testutil_spawn(testutil_scratch("own-w.log"), "worker", "--connect", wep,
                                  "--threads", "1", "--name", "render1", "--key", key[0],
                                  "--master-key", MASTER_PUB, "--cache", testutil_scratch("c5"),
                                  NULL);
    r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "4", "--wait", "-o",
            testutil_scratch("own2.exr"), "--quiet", "--key", alice, "--master-key", MASTER_PUB,
            NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "submit --wait: exit %d: %s\nmaster log:", r->status, r->err);
    testutil_wait_file_has(mlog, "(key 'alice'): fetched tiny.exr of job 2");
    testutil_stop(worker, SIGTERM);
    testutil_stop(master, SIGTERM);

    /* After a restart the owner is still alice's (the endpoints file is the old master's until
     * the new one has bound its sockets). */
    char endpoints[800];
    snprintf(endpoints, sizeof endpoints, "%s/endpoints", spool);
    (void)unlink(endpoints);
    snprintf(mlog, sizeof mlog, "%s", testutil_scratch("own-master2.log"));
    master = testutil_spawn(mlog, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                            "tcp://127.0.0.1:*", "--spool", spool, "--key", testutil_master_key(),
                            "--authorized-workers", aw, "--authorized-clients", ac,
                            "--authorized-admins", aa, "--heartbeat", "200", "--worker-failures",
                            "1", NULL);
    testutil_read_endpoints(spool, wep, cep, mlog);
    r = run("fetch", "2", "-o", testutil_scratch("bob2.exr"), "--master", cep, "--key", bob,
            "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "job 2 belongs to 'alice'");
    r = run("fetch", "2", "-o", testutil_scratch("alice2.exr"), "--master", cep, "--key", alice,
            "--master-key", MASTER_PUB, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "owner's fetch after a restart: %s\nmaster log:", r->err);
    testutil_assert_same_pixels(testutil_scratch("own2.exr"), testutil_scratch("alice2.exr"));

    /* A worker's key blocked by its strikes (here one: tasks it held when it said HELLO again)
     * is on the blocklist as key:NAME, and every hint names that entry as `unblock` takes it. */
    r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--res", "64x64", "--spp", "256",
            "--key", alice, "--master-key", MASTER_PUB, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "submit: exit %d: %s\nmaster log:", r->status, r->err);
    const char *node_args[] = {"worker",
                               "--connect",
                               wep,
                               "--threads",
                               "1",
                               "--name",
                               "node07",
                               "--key",
                               key[0],
                               "--master-key",
                               MASTER_PUB,
                               "--cache",
                               testutil_scratch("c6"),
                               NULL};
    worker = testutil_spawn_argv(testutil_scratch("node-w1.log"), node_args);
    for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(50)) {
        r = run("logs", "3", "--master", cep, "--key", alice, "--master-key", MASTER_PUB, NULL);
        if (r->status == 0 && strstr(r->out, "assigned to worker"))
            break;
        if (testutil_now_s() > until)
            testutil_fail_quoting(mlog, "no task of job 3 assigned:\n%s\nmaster log:", r->out);
    }
    /* Stopped, its connection stays open: the second one's HELLO takes the tasks it holds. */
    assert_int_equal(kill(worker, SIGSTOP), 0);
    pid_t second = testutil_spawn_argv(testutil_scratch("node-w2.log"), node_args);
    testutil_wait_file_has(mlog, "blocked from every job: 1 strike in a row");
    testutil_wait_file_has(mlog, "(`prismfarm unblock key:render1`)");
    testutil_stop(worker, SIGKILL);
    testutil_stop(second, SIGTERM);
    worker = testutil_spawn_argv(testutil_scratch("node-w3.log"), node_args);
    testutil_wait_file_has(mlog, "is on the blocklist: it gets no task until "
                                 "`prismfarm unblock key:render1`");
    r = run("unblock", "node07", "--master", cep, "--key", carol, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "worker 'node07' is blocked with its key: `prismfarm unblock key:render1`");
    r = run("unblock", "key:render1", "--master", cep, "--key", carol, "--master-key", MASTER_PUB,
            NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "unblock key:render1: %s\nmaster log:", r->err);
    testutil_wait_file_has(mlog, "worker 'key:render1' unblocked by carol");
    testutil_stop(worker, SIGTERM);
    testutil_stop(master, SIGTERM);
    env_keys(1);
}

/* A tcp:// master without keys refuses to start, with the reason and the two ways out;
 * inconsistent security options are bad command lines (status 2) too. */
static void test_master_refuses_plain_tcp(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("nokeys-spool");
    const run_t *r = run("master", "--workers", "tcp://127.0.0.1:*", "--clients",
                         "tcp://127.0.0.1:*", "--spool", spool, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "tcp://127.0.0.1:* is a network endpoint");
    expect_in(r->err, "--key FILE and --authorized DIR");
    expect_in(r->err, "--insecure");
    expect_in(r->err, "docs/security.md");
    struct stat st;
    assert_int_not_equal(stat(spool, &st), 0); /* it started nothing */

    r = run("master", "--spool", spool, "--key", testutil_master_key(), NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--key needs --authorized DIR");
    r = run("master", "--spool", spool, "--key", testutil_master_key(), "--authorized",
            testutil_authorized(), "--insecure", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "exclude each other");
    r = run("master", "--spool", spool, "--key", MASTER_PUB, "--authorized", testutil_authorized(),
            NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "no 'secret-key = ...' line");
    r = run("master", "--spool", spool, "--key", testutil_master_key(), "--authorized",
            testutil_scratch("nowhere"), NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "cannot open the folder");
}

/* --insecure: a plain-text farm on tcp:// completes a job, and says what it is; a client with
 * keys is told the master does not use CURVE. On ipc:// no flag is needed. */
static void test_insecure_and_local(void **state)
{
    (void)state;
    env_keys(0);
    const char *spool = testutil_scratch("plain-spool"),
               *mlog = testutil_scratch("plain-master.log");
    pid_t master = testutil_spawn(mlog, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                                  "tcp://127.0.0.1:*", "--spool", spool, "--heartbeat", "200",
                                  "--tile", "8", "--insecure", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog);
    testutil_expect_file_has(mlog, "plain text (--insecure)");
    pid_t worker =
        testutil_spawn(testutil_scratch("plain-w.log"), "worker", "--connect", wep, "--threads",
                       "1", "--name", "pw", "--cache", testutil_scratch("pc"), "--insecure", NULL);
    const run_t *r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "2", "--wait",
                         "-o", testutil_scratch("plain.exr"), "--quiet", "--insecure", NULL);
    if (r->status != 0)
        fail_msg("submit --wait --insecure: exit %d: %s", r->status, r->err);
    r = run("jobs", "--master", cep, "--key", FARM_KEY, "--master-key", MASTER_PUB, NULL);
    assert_int_equal(r->status, 1);
    if (!strstr(r->err, "does not use CURVE") && !strstr(r->err, "does it use CURVE"))
        fail_msg("a CURVE client was not told the master runs in plain text: %s", r->err);
    testutil_stop(worker, SIGTERM);
    testutil_stop(master, SIGTERM);

    /* ipc:// stays on this host: no keys, no flag. */
    char wipc[700], cipc[700];
    snprintf(wipc, sizeof wipc, "ipc://%s", testutil_scratch("w.ipc"));
    snprintf(cipc, sizeof cipc, "ipc://%s", testutil_scratch("c.ipc"));
    spool = testutil_scratch("ipc-spool");
    mlog = testutil_scratch("ipc-master.log");
    master = testutil_spawn(mlog, "master", "--workers", wipc, "--clients", cipc, "--spool", spool,
                            NULL);
    testutil_read_endpoints(spool, wep, cep, mlog);
    r = run("jobs", "--master", cipc, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "jobs over ipc://: exit %d: %s\nmaster log:", r->status,
                              r->err);
    testutil_stop(master, SIGTERM);
    env_keys(1);
}

/* The dashboard's actions on a keyed master (docs/dashboard.md, "Tokens"): each key's
 * NAME.token, found through the .pub files of the master's role folders, acts as the key; a
 * user (a client key) may cancel only the jobs it submitted, an admin key any, a worker's key
 * nothing. */
static void test_dashboard_tokens(void **state)
{
    (void)state;
    env_keys(0);
    char cmd[4000];
    const char *bin = getenv("PRISMFARM_BIN");
    const char *k = testutil_scratch("dashkeys"), *aw = testutil_scratch("dash-workers"),
               *ac = testutil_scratch("dash-clients"), *aa = testutil_scratch("dash-admins");
    snprintf(cmd, sizeof cmd,
             "set -e; for n in render1 alice bob carol; do '%s' keygen $n --dir '%s' >/dev/null; "
             "done; mkdir -p '%s' '%s' '%s'; cp '%s/render1.pub' '%s/'; cp '%s/alice.pub' "
             "'%s/bob.pub' '%s/'; cp '%s/carol.pub' '%s/'",
             bin, k, aw, ac, aa, k, aw, k, k, ac, k, aa);
    assert_int_equal(system(cmd), 0);
    const char *names[4] = {"render1", "alice", "bob", "carol"};
    char token[4][80], key[4][700];
    for (int i = 0; i < 4; i++) {
        char path[700];
        snprintf(path, sizeof path, "%s/%s.token", k, names[i]);
        char *text = testutil_slurp(path, NULL);
        assert_non_null(text);
        const char *t = text + strlen(text) - 1; /* the last line: the token */
        while (t > text && t[-1] != '\n')
            t--;
        snprintf(token[i], sizeof token[i], "%.64s", t);
        free(text);
        snprintf(key[i], sizeof key[i], "%s/%s.key", k, names[i]);
    }
    const char *spool = testutil_scratch("dash-spool");
    char mlog[700];
    snprintf(mlog, sizeof mlog, "%s", testutil_scratch("dash-master.log"));
    pid_t master = testutil_spawn(mlog, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                                  "tcp://127.0.0.1:*", "--spool", spool, "--key",
                                  testutil_master_key(), "--authorized-workers", aw,
                                  "--authorized-clients", ac, "--authorized-admins", aa,
                                  "--http", "0", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog);
    int port = testutil_http_port(spool);
    /* Jobs 1 and 2 by alice, no worker: they stay queued. */
    for (int i = 0; i < 2; i++) {
        const run_t *r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "4",
                             "--quiet", "--key", key[1], "--master-key", MASTER_PUB, NULL);
        if (r->status != 0)
            testutil_fail_quoting(mlog, "submit: exit %d: %s\nmaster log:", r->status, r->err);
    }
    static char out[1 << 16];
    /* Reads follow the owner rule (issue 26, finding 3): nothing of a job without a token;
     * its figures with any client key's; its log and tasks with its owner's or an admin's. */
    assert_int_equal(testutil_http(port, "GET", "/api/jobs/1", NULL, NULL, out, sizeof out), 401);
    assert_int_equal(testutil_http(port, "GET", "/api/jobs/1", token[2], NULL, out, sizeof out),
                     200);
    expect_in(out, "\"owner\":\"alice\"");
    expect_in(out, "\"can_read\":false");
    assert_int_equal(
        testutil_http(port, "GET", "/api/jobs/1/log", token[2], NULL, out, sizeof out), 403);
    expect_in(out, "job 1 belongs to 'alice'");
    assert_int_equal(
        testutil_http(port, "GET", "/api/jobs/1/tasks", token[2], NULL, out, sizeof out), 403);
    assert_int_equal(
        testutil_http(port, "GET", "/api/jobs/1/log", token[1], NULL, out, sizeof out), 200);
    assert_int_equal(
        testutil_http(port, "GET", "/api/jobs/1/tasks", token[3], NULL, out, sizeof out), 200);
    assert_int_equal(
        testutil_http(port, "GET", "/api/jobs/1/log", token[0], NULL, out, sizeof out), 401);
    assert_int_equal(testutil_http(port, "GET", "/api/jobs/1", token[1], NULL, out, sizeof out),
                     200);
    expect_in(out, "\"owner\":\"alice\"");
    assert_int_equal(testutil_http(port, "GET", "/api/whoami", token[3], NULL, out, sizeof out),
                     200);
    expect_in(out, "{\"name\":\"carol\",\"admin\":true}");
    /* bob may not cancel alice's job, nor may a worker's key; alice may. */
    assert_int_equal(
        testutil_http(port, "POST", "/api/jobs/1/cancel", token[2], "", out, sizeof out), 403);
    expect_in(out, "job 1 belongs to 'alice'");
    assert_int_equal(
        testutil_http(port, "POST", "/api/jobs/1/cancel", token[0], "", out, sizeof out), 401);
    assert_int_equal(testutil_http(port, "GET", "/api/jobs/1", token[1], NULL, out, sizeof out),
                     200);
    expect_in(out, "\"state\":\"queued\"");
    assert_int_equal(
        testutil_http(port, "POST", "/api/jobs/1/cancel", token[1], "", out, sizeof out), 200);
    testutil_wait_file_has(mlog, "job 1 'tiny': cancel from the dashboard by 'alice'");
    /* The admin cancels the other. */
    assert_int_equal(
        testutil_http(port, "POST", "/api/jobs/2/cancel", token[3], "", out, sizeof out), 200);
    testutil_wait_file_has(mlog, "cancel from the dashboard by 'carol' (admin)");
    const run_t *r = run("jobs", "--master", cep, "--json", "--key", key[2], "--master-key",
                         MASTER_PUB, NULL);
    assert_int_equal(r->status, 0);
    assert_int_equal(testutil_count_in(r->out, "\"cancelled\""), 2);
    testutil_stop(master, SIGTERM);
    env_keys(1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_keygen_files),       cmocka_unit_test(test_key_file_errors),
        cmocka_unit_test(test_farm_with_keys),     cmocka_unit_test(test_master_refuses_plain_tcp),
        cmocka_unit_test(test_insecure_and_local), cmocka_unit_test(test_roles),
        cmocka_unit_test(test_owners),             cmocka_unit_test(test_dashboard_tokens),
    };
    return cmocka_run_group_tests(tests, group_setup, testutil_scratch_teardown);
}
