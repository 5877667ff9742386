/* A damaged journal or checkpoint between two runs of a master (issue 16, items 5 and 6): a
 * checkpoint with one flipped bit or 64 bytes of garbage after it, a WAL cut in half (a power
 * cut), a WAL garbled or deleted, the journal lost. Each master is killed with SIGKILL at a moment read off the journal
 * (a checkpoint, or two, and results after them: never a timer), the files are damaged, and a
 * master started again on the spool must finish the job with exactly the pixels of an
 * uninterrupted render, or, where the job's record itself is gone, name the job in its log and
 * list it as failed with the reason. Quick: tiny.pbrt at 24x16 pixels. */
#define CLI_RUN_TIMEOUT_MS 180000
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cli_run.h"
#include "farm_testutil.h"
#include "journal_testutil.h"

#include <dirent.h>
#include <sqlite3.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define SCENE "data/render/tiny.pbrt"
/* 11 passes. A checkpoint follows the results' bytes (persist.c: about 4 passes' results of
 * this image, whatever their spp), so the second comes after about pass 8, when 1/8 of the
 * samples are rendered: the job is far from done when the master is killed on any machine (the
 * kill's pass is printed, and the test fails if the job was over). What the restarted master
 * renders is the test's cost: half of what 2048 spp (12 passes) took, a quarter of 8192. */
#define SPP "1024"
#define NPASSES 11

static const char *reference(void)
{
    return testutil_journal_reference(SCENE, SPP, "tiny-ref.exr");
}

typedef struct farm {
    const char *spool;
    char wep[256], cep[256];
    pid_t master, worker;
    /* The newest checkpoint when the master was killed: the generation the journal named, or a
     * newer one whose file a thread had written and the loop not yet journaled (persist.c). */
    long long checkpoint;
} farm_t;

/* A master and one worker on a fresh spool, job 1 submitted, the master killed with SIGKILL once
 * the journal names checkpoint generation min_gen or later and holds results after it. */
static void run_until_checkpoint(farm_t *f, const char *tag, int min_gen)
{
    char name[64];
    snprintf(name, sizeof name, "%s-spool", tag);
    f->spool = strdup(testutil_scratch(name));
    snprintf(name, sizeof name, "%s-master1.log", tag);
    const char *mlog = testutil_scratch(name);
    f->master = testutil_journal_master(mlog, f->spool, "tcp://127.0.0.1:*", "tcp://127.0.0.1:*");
    testutil_read_endpoints(f->spool, f->wep, f->cep, mlog);
    snprintf(name, sizeof name, "%s-w.log", tag);
    f->worker = testutil_journal_worker(testutil_scratch(name), f->wep, "w");
    const run_t *r = run("submit", SCENE, "--master", f->cep, "--spp", SPP, "--insecure", NULL);
    if (r->status != 0)
        fail_msg("submit: exit %d: %s", r->status, r->err);
    assert_string_equal(r->out, "1\n");
    char sql[128];
    snprintf(sql, sizeof sql, "SELECT checkpoint >= %d FROM jobs WHERE id=1", min_gen);
    testutil_wait_journal(f->spool, test_wait_s(), "a checkpoint and results after it", sql,
                 "SELECT COUNT(*) FROM results WHERE job=1 AND kind=0", NULL);
    testutil_stop(f->master, SIGKILL);
    f->checkpoint = testutil_journal_query(f->spool, "SELECT checkpoint FROM jobs WHERE id=1");
    long long pass = testutil_journal_query(f->spool, "SELECT MAX(pass) FROM passes WHERE job=1");
    print_message("%s: master killed at checkpoint %lld after pass %lld of %d\n", tag,
                  f->checkpoint, pass, NPASSES);
    /* The job was not over: what the test damages is still needed. */
    assert_true(testutil_journal_query(f->spool, "SELECT state FROM jobs WHERE id=1") < 2);
    char dir[700];
    snprintf(dir, sizeof dir, "%s/jobs/1", f->spool);
    DIR *d = opendir(dir);
    assert_non_null(d);
    for (struct dirent *e; (e = readdir(d));) {
        long long gen;
        char tail[8];
        if (sscanf(e->d_name, "checkpoint-%lld.bi%1s", &gen, tail) == 2 &&
            !strstr(e->d_name, ".tmp") && gen > f->checkpoint)
            f->checkpoint = gen;
    }
    closedir(d);
}

static const char *checkpoint_path(const farm_t *f, long long gen)
{
    static char path[700];
    snprintf(path, sizeof path, "%s/jobs/1/checkpoint-%lld.bin", f->spool, gen);
    return path;
}

/* A second master on the spool: job 1 must end done with the reference's pixels. Returns the
 * second master's log (malloc'ed). */
static char *finish(farm_t *f, const char *tag)
{
    char name[64];
    snprintf(name, sizeof name, "%s-master2.log", tag);
    const char *mlog = testutil_scratch(name);
    f->master = testutil_journal_master(mlog, f->spool, f->wep, f->cep);
    snprintf(name, sizeof name, "%s-out.exr", tag);
    testutil_journal_finish(f->cep, reference(), testutil_scratch(name), mlog);
    testutil_stop(f->worker, SIGTERM);
    testutil_stop(f->master, SIGTERM);
    return testutil_slurp(mlog, NULL);
}

static void expect_log(const char *log, const char *needle)
{
    if (!log || !strstr(log, needle))
        fail_msg("the master's log has no '%s':\n%s", needle, log ? log : "(none)");
}

/* Item 5: one bit flipped in the middle of the newest checkpoint's image. Before checkpoints
 * carried a checksum this gave a done job with one wrong value; now the checkpoint is refused by
 * its SHA-256, the job falls back to the previous one and renders the rest again. */
static void test_checkpoint_bit_flipped(void **state)
{
    (void)state;
    farm_t f = {0};
    run_until_checkpoint(&f, "flip", 2);
    const char *path = checkpoint_path(&f, f.checkpoint);
    /* A high mantissa bit of bucket sum 100 (pixel 12's fifth bucket): its value moves by
     * 1/32 or so. The header is 40 bytes (36 in the format without a checksum, magic "PFCX",
     * which the test met before the fix). */
    FILE *fp = fopen(path, "r+b");
    assert_non_null(fp);
    char magic[4];
    assert_int_equal(fread(magic, 1, 4, fp), 4);
    long offset = (memcmp(magic, "PFCX", 4) == 0 ? 36 : 40) + 8 * 100 + 6;
    assert_int_equal(fseek(fp, offset, SEEK_SET), 0);
    int c = fgetc(fp);
    assert_true(c >= 0);
    assert_int_equal(fseek(fp, offset, SEEK_SET), 0);
    assert_int_equal(fputc(c ^ 0x08, fp), c ^ 0x08);
    fclose(fp);
    char *log = finish(&f, "flip");
    char needle[900];
    snprintf(needle, sizeof needle, "job 1 'tiny': checkpoint %s fails its SHA-256", path);
    expect_log(log, needle);
    expect_log(log, "trying the previous checkpoint");
    free(log);
    free((char *)f.spool);
}

/* Item 5: 64 bytes of garbage after the only checkpoint (the master killed right after its
 * first). Before, the job rendered to the end and then failed; now the checkpoint is refused
 * and the job renders its merged passes again. */
static void test_checkpoint_garbage_appended(void **state)
{
    (void)state;
    farm_t f = {0};
    run_until_checkpoint(&f, "garbage", 1);
    /* Every checkpoint in the folder gets the garbage, so nothing older can stand in. */
    for (long long g = f.checkpoint; g >= 1; g--) {
        FILE *fp = fopen(checkpoint_path(&f, g), "ab");
        if (!fp)
            continue;
        for (int i = 0; i < 64; i++)
            fputc((i * 37 + 11) & 0xff, fp);
        fclose(fp);
    }
    char *log = finish(&f, "garbage");
    expect_log(log, "job 1 'tiny': checkpoint");
    expect_log(log, "its merged passes are rendered again");
    free(log);
    free((char *)f.spool);
}

/* Item 6: the WAL cut in half after the master died, as a power cut may leave it. The journal
 * then names an older checkpoint, which the master used to delete once the next one was
 * journaled (the job failed); now the previous checkpoint stays and any checkpoint on disk that
 * checks out is a right starting point. */
static void test_wal_cut_in_half(void **state)
{
    (void)state;
    farm_t f = {0};
    run_until_checkpoint(&f, "walcut", 2);
    char wal[700];
    snprintf(wal, sizeof wal, "%s/journal.db-wal", f.spool);
    struct stat st;
    assert_int_equal(stat(wal, &st), 0);
    assert_int_equal(truncate(wal, st.st_size / 2), 0);
    char *log = finish(&f, "walcut");
    free(log);
    free((char *)f.spool);
}

/* Item 6: a garbled WAL (every byte past its header inverted): SQLite drops every frame. The
 * job's record was copied into journal.db when it was submitted (journal_checkpoint_wal, issue
 * 26): the job goes on from there (its checkpoints and results in the WAL are gone: rendered
 * again) to the reference's pixels. Before, the journal forgot job 1 altogether. */
static void test_wal_garbled(void **state)
{
    (void)state;
    farm_t f = {0};
    run_until_checkpoint(&f, "walbad", 1);
    char wal[700];
    snprintf(wal, sizeof wal, "%s/journal.db-wal", f.spool);
    size_t size;
    char *data = testutil_slurp(wal, &size);
    assert_non_null(data);
    assert_true(size > 64);
    for (size_t i = 32; i < size; i++)
        data[i] = (char)~data[i];
    FILE *fp = fopen(wal, "wb");
    assert_non_null(fp);
    assert_int_equal(fwrite(data, 1, size, fp), size);
    fclose(fp);
    free(data);
    free(finish(&f, "walbad"));
    free((char *)f.spool);
}

/* Issue 26, finding 6: journal.db-wal deleted while the master is down (an operator tidying up,
 * a backup that copies journal.db alone). An acknowledged job is in journal.db itself: it
 * finishes, with the reference's pixels. On the code before, it was lost (only named in the
 * log, listed as failed). */
static void test_wal_deleted(void **state)
{
    (void)state;
    farm_t f = {0};
    run_until_checkpoint(&f, "waldel", 1);
    char wal[700];
    snprintf(wal, sizeof wal, "%s/journal.db-wal", f.spool);
    assert_int_equal(unlink(wal), 0);
    char *log = finish(&f, "waldel");
    if (log && strstr(log, "is in the spool but not in the journal"))
        fail_msg("the deleted WAL lost job 1:\n%s", log);
    free(log);
    free((char *)f.spool);
}

/* The journal itself lost (journal.db and its WAL deleted, or damaged beyond reading): job 1 is
 * not dropped in silence -- the log names it, and it is listed as failed with the reason; the
 * next job gets an id past it. */
static void test_journal_lost(void **state)
{
    (void)state;
    farm_t f = {0};
    run_until_checkpoint(&f, "dblost", 1);
    const char *files[] = {"journal.db", "journal.db-wal", "journal.db-shm"};
    for (int k = 0; k < 3; k++) {
        char path[700];
        snprintf(path, sizeof path, "%s/%s", f.spool, files[k]);
        (void)unlink(path);
    }
    const char *mlog = testutil_scratch("dblost-master2.log");
    f.master = testutil_journal_master(mlog, f.spool, f.wep, f.cep);
    const run_t *r = run("status", "1", "--master", f.cep, "--insecure", NULL);
    char *log = testutil_slurp(mlog, NULL);
    if (r->status != 0 || !strstr(r->out, "failed"))
        testutil_fail_quoting(mlog, "status 1: exit %d: %s\n%s\nmaster log:", r->status, r->err,
                              r->out);
    expect_log(log, "job 1: its folder ");
    expect_log(log, "is in the spool but not in the journal");
    free(log);
    r = run("status", "1", "--json", "--master", f.cep, "--insecure", NULL);
    assert_int_equal(r->status, 0);
    assert_non_null(strstr(r->out, "the journal lost its record"));
    /* The next job gets an id past it. */
    r = run("submit", SCENE, "--master", f.cep, "--spp", "4", "--insecure", NULL);
    assert_int_equal(r->status, 0);
    assert_string_equal(r->out, "2\n");
    testutil_stop(f.worker, SIGTERM);
    testutil_stop(f.master, SIGTERM);
    free((char *)f.spool);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_checkpoint_bit_flipped, testutil_kill_children),
        cmocka_unit_test_teardown(test_checkpoint_garbage_appended, testutil_kill_children),
        cmocka_unit_test_teardown(test_wal_cut_in_half, testutil_kill_children),
        cmocka_unit_test_teardown(test_wal_garbled, testutil_kill_children),
        cmocka_unit_test_teardown(test_wal_deleted, testutil_kill_children),
        cmocka_unit_test_teardown(test_journal_lost, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
