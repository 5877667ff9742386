/* The master's journal (master/journal.h, docs/reliability.md): its blobs and tables on their
 * own, then whole farms on loopback whose master is killed with SIGKILL mid-job and started
 * again on the same spool, and a farm whose master, workers and client are killed at seeded
 * random moments: each job must end with exactly the pixels of a run that was never
 * interrupted. The moments of the two targeted kills are read off the journal itself (a
 * checkpoint and results after it, photon batches before the store), so they do not depend on
 * the machine's speed. */
#define CLI_RUN_TIMEOUT_MS 180000
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cli_run.h"
#include "farm_testutil.h"
#include "journal.h"
#include "journal_db.h" /* JOURNAL_VERSION */
#include "journal_testutil.h"
#include "rng.h"

#include <dirent.h>
#include <math.h>
#include <sqlite3.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

/* A sample's XYZ when only its luminance Y matters to the test. */
#define XYZ_OF_Y(l) ((const double[3]){0.0, (l), 0.0})

#define SCENE "data/render/tiny.pbrt"
/* The random kills: 12 passes, 2^(p-12) of the samples done after pass p; the kills wait for
 * passes (test_random_kills), not for the clock. About 1.3 CPU s in a Release build. */
#define SPP_LONG "2048"
#define NPASSES_LONG 12
#define PHOTON_SCENE "data/photon/beam_big.pbrt"
#define STOKES_SCENE "data/render/stokes.pbrt"
/* tiny.pbrt: 11 passes, 0.6 CPU s in a Release build. The targeted kills come at the first
 * checkpoint with results after it, a few passes in (a checkpoint follows the results' bytes,
 * persist.c), with most of the samples left for the restarted master: the test's cost. */
#define SPP "1024"
/* beam_big: 1.5 M photons, then a camera phase of 8 passes: the second master is killed at the
 * phase's first results, with all but a pass of 1 spp of it left to render. */
#define PHOTON_SPP "128"

/* ---------------------------------------------------------------- blobs and tables */

static void test_tile_blob_round_trip(void **state)
{
    (void)state;
    enum { W = 3, H = 2, NB = 4 };
    double sums[W * H * NB], xyz[W * H * TILEBUF_XYZ], lum[W * H], lum_sq[W * H];
    uint64_t counts[W * H];
    for (int i = 0; i < W * H * NB; i++)
        sums[i] = 0.1 * i - 0.7;
    for (int i = 0; i < W * H * TILEBUF_XYZ; i++)
        xyz[i] = 0.3 * i + 0.01;
    for (int i = 0; i < W * H; i++) {
        counts[i] = (uint64_t)(i + 1);
        lum[i] = 1.0 / (i + 1);
        lum_sq[i] = 3.0 * i;
    }
    proto_tile_result_t t = {.rect = {.x0 = 8, .y0 = 16, .w = W, .h = H, .sample_begin = 4,
                                      .sample_end = 8},
                             .nbuckets = NB, .sums = sums, .xyz = xyz, .counts = counts, .lum = lum,
                             .lum_sq = lum_sq, .nonfinite = 5};
    uint8_t *blob;
    size_t size;
    err_t err;
    assert_int_equal(journal_pack_tile(&t, &blob, &size, &err), 0);
    uint32_t sb, se;
    tilebuf_t *tb = journal_unpack_tile(blob, size, &sb, &se, &err);
    assert_non_null(tb);
    assert_int_equal(sb, 4);
    assert_int_equal(se, 8);
    assert_int_equal(tilebuf_x0(tb), 8);
    assert_int_equal(tilebuf_y0(tb), 16);
    assert_int_equal(tilebuf_width(tb), W);
    assert_int_equal(tilebuf_nbuckets(tb), NB);
    assert_int_equal(tilebuf_nonfinite(tb), 5);
    assert_memory_equal(tilebuf_sums(tb), sums, sizeof sums);
    assert_memory_equal(tilebuf_xyz_sums(tb), xyz, sizeof xyz);
    assert_memory_equal(tilebuf_counts(tb), counts, sizeof counts);
    assert_memory_equal(tilebuf_luminance_sums(tb), lum, sizeof lum);
    assert_memory_equal(tilebuf_luminance_sq_sums(tb), lum_sq, sizeof lum_sq);
    tilebuf_destroy(&tb);
    /* Cut short, one byte too many, another magic, a non-finite sum: refused, never a tile. */
    assert_null(journal_unpack_tile(blob, size - 1, &sb, &se, &err));
    assert_non_null(strstr(err.msg, "cut short"));
    uint8_t *longer = malloc(size + 1);
    memcpy(longer, blob, size);
    longer[size] = 0;
    assert_null(journal_unpack_tile(longer, size + 1, &sb, &se, &err));
    assert_non_null(strstr(err.msg, "past its arrays"));
    free(longer);
    blob[0] ^= 0xff;
    assert_null(journal_unpack_tile(blob, size, &sb, &se, &err));
    assert_non_null(strstr(err.msg, "no valid header"));
    free(blob);
    sums[5] = 1.0 / 0.0;
    assert_int_equal(journal_pack_tile(&t, &blob, &size, &err), 0);
    assert_null(journal_unpack_tile(blob, size, &sb, &se, &err));
    free(blob);

    /* Sums that are float values (tilebuf_round_sums's output, as a float32 RESULT brings them)
     * are kept as float32 with the XYZ sums: a 44-byte header, 4 bytes a sum (nb + 3 a pixel),
     * 24 a pixel for counts, lum and lum_sq; they come back as the same doubles. One double
     * among them keeps all at 8 bytes. */
    for (int i = 0; i < W * H * TILEBUF_XYZ; i++)
        xyz[i] = (double)(float)(0.3 * i + 0.01);
    for (int i = 0; i < W * H * NB; i++)
        sums[i] = (double)(float)(0.1 * i - 0.7);
    sums[3] = -0.0;
    sums[4] = 0x1.fffffep127; /* FLT_MAX */
    assert_int_equal(journal_pack_tile(&t, &blob, &size, &err), 0);
    assert_int_equal(size, 44 + W * H * (NB + TILEBUF_XYZ) * 4 + W * H * 24);
    tb = journal_unpack_tile(blob, size, &sb, &se, &err);
    assert_non_null(tb);
    assert_memory_equal(tilebuf_sums(tb), sums, sizeof sums);
    assert_memory_equal(tilebuf_xyz_sums(tb), xyz, sizeof xyz);
    assert_memory_equal(tilebuf_luminance_sq_sums(tb), lum_sq, sizeof lum_sq);
    assert_int_equal(tilebuf_nonfinite(tb), 5);
    tilebuf_destroy(&tb);
    assert_null(journal_unpack_tile(blob, size - 1, &sb, &se, &err));
    assert_non_null(strstr(err.msg, "cut short"));
    /* A blob of journal version 4 (no XYZ sums, magic "PFTK") is refused by name. */
    uint32_t old_magic = 0x4b544650u, magic;
    memcpy(&magic, blob, 4);
    memcpy(blob, &old_magic, 4);
    assert_null(journal_unpack_tile(blob, size, &sb, &se, &err));
    assert_non_null(strstr(err.msg, "version 4 (no XYZ sums)"));
    memcpy(blob, &magic, 4);
    uint32_t bits = 48; /* the width field, after magic and seven header words */
    memcpy(blob + 32, &bits, 4);
    assert_null(journal_unpack_tile(blob, size, &sb, &se, &err));
    assert_non_null(strstr(err.msg, "no valid header"));
    free(blob);
    sums[4] = 1e-39; /* below float's normal range: a double */
    assert_int_equal(journal_pack_tile(&t, &blob, &size, &err), 0);
    assert_int_equal(size, 44 + W * H * (NB + TILEBUF_XYZ) * 8 + W * H * 24);
    tb = journal_unpack_tile(blob, size, &sb, &se, &err);
    assert_non_null(tb);
    assert_memory_equal(tilebuf_sums(tb), sums, sizeof sums);
    tilebuf_destroy(&tb);
    free(blob);
}

static void test_photon_blob_round_trip(void **state)
{
    (void)state;
    const uint8_t store[] = {'P', 'F', 'P', 'M', 1, 2, 3, 4, 5};
    proto_photon_result_t r = {.range = {.first = 20000, .end = 40000}, .emitted = 320000,
                               .data = store, .size = sizeof store, .nonfinite = 2};
    uint8_t *blob;
    size_t size;
    err_t err;
    assert_int_equal(journal_pack_photons(&r, &blob, &size, &err), 0);
    proto_photon_result_t back;
    assert_int_equal(journal_unpack_photons(blob, size, &back, &err), 0);
    assert_int_equal(back.range.first, 20000);
    assert_int_equal(back.range.end, 40000);
    assert_int_equal(back.emitted, 320000);
    assert_int_equal(back.nonfinite, 2);
    assert_int_equal(back.size, sizeof store);
    assert_memory_equal(back.data, store, sizeof store);
    assert_int_equal(journal_unpack_photons(blob, 20, &back, &err), -1);
    free(blob);
}

static void test_checkpoint_round_trip(void **state)
{
    (void)state;
    err_t err;
    tilebuf_t *img = tilebuf_new(0, 0, 5, 4, 3, &err);
    assert_non_null(img);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 5; x++) {
            double b[3] = {x + 0.25, y * 1e-9, 1e12};
            tilebuf_add_sample(img, x, y, b, XYZ_OF_Y(x * y + 0.5));
        }
    int next[4] = {3, 2, 2, 0}, back[4];
    const char *path = testutil_scratch("ckpt.bin");
    assert_int_equal(journal_write_checkpoint(path, 0, img, next, 4, &err), 0);
    tilebuf_t *got = NULL;
    assert_int_equal(journal_read_checkpoint(path, 0, 5, 4, 3, 4, &got, back, &err), 0);
    assert_memory_equal(back, next, sizeof next);
    assert_memory_equal(tilebuf_sums(got), tilebuf_sums(img), 5 * 4 * 3 * sizeof(double));
    assert_memory_equal(tilebuf_counts(got), tilebuf_counts(img), 5 * 4 * sizeof(uint64_t));
    tilebuf_destroy(&got);
    /* One bit flipped, 64 bytes appended, another round: refused, naming the file and why. */
    {
        size_t size;
        char *bytes = testutil_slurp(path, &size);
        assert_non_null(bytes);
        bytes[40 + 8 * 7 + 6] ^= 0x08;
        FILE *f = fopen(path, "wb");
        assert_int_equal(fwrite(bytes, 1, size, f), size);
        fclose(f);
        assert_int_equal(journal_read_checkpoint(path, 0, 5, 4, 3, 4, &got, back, &err), -1);
        assert_null(got);
        assert_non_null(strstr(err.msg, "fails its SHA-256 checksum"));
        bytes[40 + 8 * 7 + 6] ^= 0x08;
        f = fopen(path, "wb");
        assert_int_equal(fwrite(bytes, 1, size, f), size);
        for (int i = 0; i < 64; i++)
            fputc(i, f);
        fclose(f);
        assert_int_equal(journal_read_checkpoint(path, 0, 5, 4, 3, 4, &got, back, &err), -1);
        assert_non_null(strstr(err.msg, "more"));
        f = fopen(path, "wb");
        assert_int_equal(fwrite(bytes, 1, size, f), size);
        fclose(f);
        free(bytes);
        assert_int_equal(journal_read_checkpoint(path, 1, 5, 4, 3, 4, &got, back, &err), -1);
        assert_non_null(strstr(err.msg, "of round 0"));
    }
    /* Another job's size, or a file cut short: an error naming the file. */
    assert_int_equal(journal_read_checkpoint(path, 0, 6, 4, 3, 4, &got, back, &err), -1);
    assert_non_null(strstr(err.msg, "ckpt.bin"));
    assert_int_equal(truncate(path, 60), 0);
    assert_int_equal(journal_read_checkpoint(path, 0, 5, 4, 3, 4, &got, back, &err), -1);
    assert_null(got);
    tilebuf_destroy(&img);
}

typedef struct seen {
    uint32_t task[16];
    int kind[16];
    int n;
} seen_t;

/* journal_blocked's callback: "name: reason;" appended to a 256-byte buffer. */
static void collect_blocked(void *user, const char *worker, const char *reason)
{
    char *buf = user;
    size_t n = strlen(buf);
    snprintf(buf + n, 256 - n, "%s: %s;", worker, reason);
}

static int collect(void *user, uint32_t task, int kind, const void *data, size_t size, err_t *err)
{
    (void)data;
    (void)size;
    (void)err;
    seen_t *s = user;
    if (s->n < 16) {
        s->task[s->n] = task;
        s->kind[s->n++] = kind;
    }
    return 0;
}

static void test_journal_tables(void **state)
{
    (void)state;
    err_t err;
    const char *dir = testutil_scratch("tables");
    char path[600];
    snprintf(path, sizeof path, "%s/journal.db", dir);
    journal_t *jn = journal_open(dir, &err);
    assert_non_null(jn);
    journal_job_t job = {.id = 7, .name = "prism", .hash = "ab12", .main = "scene.pbrt",
                         .settings = {.spp = 64, .seed = -1, .integrator = "path",
                                      .target_error = 0.02},
                         .state = 0, .round_photons = 30000, .samples_total = 999,
                         .owner = "alice"};
    assert_int_equal(journal_add_job(jn, &job, &err), 0);
    const uint8_t blob[4] = {1, 2, 3, 4};
    /* ntiles 2: task = pass * 2 + tile; a photon batch. */
    for (int pass = 0; pass < 2; pass++)
        for (int tile = 0; tile < 2; tile++)
            assert_int_equal(journal_add_result(jn, 7, 0, (uint32_t)(pass * 2 + tile), 0, tile,
                                                pass, blob, sizeof blob, &err),
                             0);
    assert_int_equal(journal_add_result(jn, 7, 0, 0x80000001u, 1, 1, -1, blob, 4, &err), 0);
    /* The same task again (a duplicate result) is ignored, not an error. */
    assert_int_equal(journal_add_result(jn, 7, 0, 3, 0, 1, 1, blob, 4, &err), 0);
    int next[2] = {1, 0};
    assert_int_equal(journal_set_checkpoint(jn, 7, 0, 1, next, 2, 12.5, &err), 0);
    seen_t s = {0};
    size_t lost;
    assert_int_equal(journal_results(jn, 7, 0, collect, &s, &lost, &err), 0);
    /* Photon batches first, then by pass and tile; tile 0's pass 0 is in the checkpoint. */
    assert_int_equal(s.n, 4);
    assert_int_equal(s.kind[0], 1);
    assert_int_equal(s.task[1], 1);
    assert_int_equal(s.task[2], 2);
    assert_int_equal(s.task[3], 3);
    assert_int_equal(journal_set_photons_saved(jn, 7, 30000, &err), 0);
    journal_pass_t p = {.pass = 3, .spp = 4, .elapsed = 1.5, .valid = true, .rel_error = 0.25};
    assert_int_equal(journal_add_pass(jn, 7, 0, &p, &err), 0);
    journal_close(&jn);

    /* Everything is there after a reopen. */
    assert_non_null(jn = journal_open(dir, &err));
    journal_job_t *rows;
    size_t n;
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 1);
    assert_string_equal(rows[0].name, "prism");
    assert_string_equal(rows[0].main, "scene.pbrt");
    assert_string_equal(rows[0].settings.integrator, "path");
    assert_null(rows[0].settings.dispersion);
    assert_int_equal(rows[0].settings.seed, -1);
    assert_true(rows[0].settings.target_error == 0.02);
    assert_int_equal(rows[0].checkpoint, 1);
    assert_int_equal(rows[0].photons_saved, 30000);
    assert_true(rows[0].elapsed == 1.5);
    assert_string_equal(rows[0].owner, "alice");
    journal_job_clear(&rows[0]);
    free(rows);
    journal_pass_t ps[4];
    assert_int_equal(journal_passes(jn, 7, 0, ps, 4, &err), 1);
    assert_int_equal(ps[0].pass, 3);
    s.n = 0;
    assert_int_equal(journal_results(jn, 7, 0, collect, &s, &lost, &err), 0);
    assert_int_equal(s.n, 3); /* the photon batch went with the saved store */
    assert_int_equal(lost, 0);
    /* Results are appended to segment files beside the database: the six blobs above (the
     * duplicate's bytes too, its row ignored) are in segment 1, which the rows still name. */
    char rdir[700], seg1[800], stray[800];
    snprintf(rdir, sizeof rdir, "%s/results/7", dir);
    snprintf(seg1, sizeof seg1, "%s/1.log", rdir);
    assert_int_equal(testutil_count_entries(rdir), 1);
    struct stat st;
    assert_int_equal(stat(seg1, &st), 0);
    assert_int_equal(st.st_size, 6 * 4);
    /* A result journaled by this (reopened) master starts a segment of its own. */
    assert_int_equal(journal_add_result(jn, 7, 0, 10, 0, 0, 5, blob, 4, &err), 0);
    assert_int_equal(testutil_count_entries(rdir), 2);
    /* Bytes that are not the ones journaled (a power cut before they reached the disk) are
     * skipped and counted: task 3's blob is the fourth in segment 1, at offset 12. */
    FILE *sf = fopen(seg1, "r+b");
    assert_non_null(sf);
    assert_int_equal(fseek(sf, 12, SEEK_SET), 0);
    assert_int_equal(fputc(0xee, sf), 0xee);
    fclose(sf);
    s.n = 0;
    assert_int_equal(journal_results(jn, 7, 0, collect, &s, &lost, &err), 0);
    assert_int_equal(s.n, 3);
    assert_int_equal(lost, 1);
    /* A segment cut short loses the results past its end: segment 2 emptied. */
    char seg2[800];
    snprintf(seg2, sizeof seg2, "%s/2.log", rdir);
    assert_int_equal(truncate(seg2, 2), 0);
    s.n = 0;
    assert_int_equal(journal_results(jn, 7, 0, collect, &s, &lost, &err), 0);
    assert_int_equal(s.n, 2);
    assert_int_equal(lost, 2);
    /* Stray files no row names are pruned (the old layout's result files, a temporary). */
    snprintf(stray, sizeof stray, "%s/0-9.bin.tmp", rdir);
    sf = fopen(stray, "w");
    fclose(sf);
    snprintf(stray, sizeof stray, "%s/9.log", rdir);
    sf = fopen(stray, "w");
    fclose(sf);
    assert_int_equal(testutil_count_entries(rdir), 4);
    journal_prune(jn, 7);
    assert_int_equal(testutil_count_entries(rdir), 2);
    /* A segment number is never reused, even past a stray file's. */
    sf = fopen(stray, "w");
    fclose(sf);
    assert_int_equal(journal_add_result(jn, 7, 0, 11, 0, 1, 5, blob, 4, &err), 0);
    snprintf(stray, sizeof stray, "%s/10.log", rdir);
    assert_int_equal(stat(stray, &st), 0);
    /* A job that is over keeps no results. */
    job.state = 2;
    assert_int_equal(journal_set_state(jn, &job, &err), 0);
    s.n = 0;
    assert_int_equal(journal_results(jn, 7, 0, collect, &s, &lost, &err), 0);
    assert_int_equal(s.n, 0);
    assert_int_equal(stat(rdir, &st), -1); /* the job's folder went with its last file */
    journal_close(&jn);

    /* A job's priority and pause, and the blocked workers, are kept (version 7). */
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_set_control(jn, 7, -3, true, &err), 0);
    assert_int_equal(journal_set_control(jn, 8, 0, false, &err), -1); /* no job 8 */
    assert_int_equal(journal_set_blocked(jn, "node9", "5 tasks failed in a row", &err), 0);
    assert_int_equal(journal_set_blocked(jn, "node2", "by hand", &err), 0);
    assert_int_equal(journal_set_blocked(jn, "node2", NULL, &err), 0);
    journal_close(&jn);
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 1);
    assert_int_equal(rows[0].priority, -3);
    assert_true(rows[0].paused);
    journal_job_clear(&rows[0]);
    free(rows);
    char blocked[256] = "";
    assert_int_equal(journal_blocked(jn, collect_blocked, blocked, &err), 0);
    assert_string_equal(blocked, "node9: 5 tasks failed in a row;");
    assert_true(journal_stats(jn).writes == 0); /* since this open: nothing written yet */
    journal_close(&jn);

    /* A job's frame fields are kept (version 8): a sequence and one of its frames. */
    assert_non_null(jn = journal_open(dir, &err));
    journal_job_t seqrecs[2] = {
        {.id = 20, .name = "walk", .hash = "ab12", .main = "walk1.pbrt", .nframes = 1},
        {.id = 21, .name = "walk1.pbrt", .hash = "ab12", .main = "walk1.pbrt",
         .parent = 20, .frame = 1}};
    assert_int_equal(journal_add_jobs(jn, seqrecs, 2, &err), 0);
    journal_close(&jn);
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 3);
    assert_int_equal(rows[0].nframes, 0);
    assert_int_equal(rows[0].parent, 0);
    assert_int_equal(rows[1].nframes, 1);
    assert_int_equal(rows[1].parent, 0);
    assert_int_equal(rows[2].parent, 20);
    assert_int_equal(rows[2].frame, 1);
    assert_int_equal(rows[2].nframes, 0);
    for (size_t i = 0; i < n; i++)
        journal_job_clear(&rows[i]);
    free(rows);
    /* All or none: a batch whose second row fails (the id of the first again, with a NULL
     * name the table refuses) leaves nothing of the batch. */
    journal_job_t badrecs[2] = {
        {.id = 30, .name = "x", .hash = "ab12", .main = "x.pbrt", .nframes = 1},
        {.id = 31, .name = NULL, .hash = "ab12", .main = "x.pbrt", .parent = 30}};
    assert_int_equal(journal_add_jobs(jn, badrecs, 2, &err), -1);
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 3);
    for (size_t i = 0; i < n; i++)
        journal_job_clear(&rows[i]);
    free(rows);
    journal_close(&jn);

    /* A version-7 journal (before sequences) is migrated in place: its jobs are single
     * scenes. */
    sqlite3 *db;
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    assert_int_equal(sqlite3_exec(db,
                                  "DELETE FROM jobs WHERE id >= 20; ALTER TABLE jobs DROP COLUMN "
                                  "parent; ALTER TABLE jobs DROP COLUMN frame; ALTER TABLE jobs "
                                  "DROP COLUMN nframes; UPDATE meta SET value=7 WHERE key='version'",
                                  NULL, NULL, NULL),
                     SQLITE_OK);
    sqlite3_close(db);
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 1);
    assert_int_equal(rows[0].parent, 0);
    assert_int_equal(rows[0].nframes, 0);
    assert_int_equal(rows[0].priority, -3); /* the rest of the row as it was */
    journal_job_clear(&rows[0]);
    free(rows);
    journal_close(&jn);

    /* A version-6 journal (before priorities) is migrated in place: priority 0, not paused. */
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    assert_int_equal(sqlite3_exec(db,
                                  "ALTER TABLE jobs DROP COLUMN priority; ALTER TABLE jobs DROP "
                                  "COLUMN paused; ALTER TABLE jobs DROP COLUMN parent; ALTER TABLE "
                                  "jobs DROP COLUMN frame; ALTER TABLE jobs DROP COLUMN nframes; "
                                  "DROP TABLE blocked; UPDATE meta SET value=6 "
                                  "WHERE key='version'",
                                  NULL, NULL, NULL),
                     SQLITE_OK);
    sqlite3_close(db);
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 1);
    assert_int_equal(rows[0].priority, 0);
    assert_false(rows[0].paused);
    journal_job_clear(&rows[0]);
    free(rows);
    blocked[0] = 0;
    assert_int_equal(journal_blocked(jn, collect_blocked, blocked, &err), 0);
    assert_string_equal(blocked, "");
    journal_close(&jn);

    /* A version-5 journal (before owners) is migrated in place: its jobs have no owner. */
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    assert_int_equal(sqlite3_exec(db,
                                  "ALTER TABLE jobs DROP COLUMN owner; ALTER TABLE jobs DROP "
                                  "COLUMN priority; ALTER TABLE jobs DROP COLUMN paused; ALTER "
                                  "TABLE jobs DROP COLUMN parent; ALTER TABLE jobs DROP COLUMN "
                                  "frame; ALTER TABLE jobs DROP COLUMN nframes; DROP "
                                  "TABLE blocked; UPDATE meta SET value=5 WHERE key='version'",
                                  NULL, NULL, NULL),
                     SQLITE_OK);
    sqlite3_close(db);
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 1);
    assert_string_equal(rows[0].name, "prism");
    assert_string_equal(rows[0].owner, "");
    journal_job_clear(&rows[0]);
    free(rows);
    journal_close(&jn);
    /* ...and marked as of the current version, so it is not migrated twice. */
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    sqlite3_stmt *vst;
    assert_int_equal(sqlite3_prepare_v2(db, "SELECT value FROM meta WHERE key='version'", -1,
                                        &vst, NULL),
                     SQLITE_OK);
    assert_int_equal(sqlite3_step(vst), SQLITE_ROW);
    assert_int_equal(sqlite3_column_int(vst, 0), JOURNAL_VERSION);
    sqlite3_finalize(vst);
    sqlite3_close(db);

    /* Version 10 keeps a column per setting (proto/job_settings.h), adaptive sampling's too. A
     * version-9 journal, which kept it as the sign of target_error, is migrated in place: the
     * column is added and a negative target becomes the flag. */
    assert_non_null(jn = journal_open(dir, &err));
    journal_job_t adaptive = job;
    adaptive.id = 8;
    adaptive.settings.adaptive = 1;
    adaptive.settings.time_limit = 90.5;
    adaptive.settings.dispersion = "fanout";
    assert_int_equal(journal_add_job(jn, &adaptive, &err), 0);
    journal_close(&jn);
    assert_int_equal(testutil_journal_query(dir, "SELECT adaptive FROM jobs WHERE id=8"), 1);
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    assert_int_equal(sqlite3_exec(db,
                                  "UPDATE jobs SET target_error=-target_error WHERE adaptive=1; "
                                  "ALTER TABLE jobs DROP COLUMN adaptive; UPDATE meta SET value=9 "
                                  "WHERE key='version'",
                                  NULL, NULL, NULL),
                     SQLITE_OK);
    sqlite3_close(db);
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 2);
    assert_int_equal(rows[0].settings.adaptive, 0);
    assert_true(rows[0].settings.target_error == 0.02);
    assert_int_equal(rows[1].settings.adaptive, 1);
    assert_true(rows[1].settings.target_error == 0.02);
    assert_true(rows[1].settings.time_limit == 90.5);
    assert_string_equal(rows[1].settings.dispersion, "fanout");
    assert_ptr_equal(rows[1].settings.dispersion, rows[1].setting_names.dispersion);
    for (size_t i = 0; i < n; i++)
        journal_job_clear(&rows[i]);
    free(rows);
    journal_close(&jn);
    assert_int_equal(testutil_journal_query(dir, "SELECT value FROM meta WHERE key='version'"),
                     JOURNAL_VERSION);

    /* Version 11 keeps the plan's polarisation decision (render/polar_pilot.h), so that a
     * restarted master does not decide again: a job's 2 ("on") comes back as it went in, and a
     * version-10 journal gets the column with 0, the file's, as its jobs ran. */
    assert_non_null(jn = journal_open(dir, &err));
    journal_job_t polar = job;
    polar.id = 9;
    polar.settings.polarized = 2;
    assert_int_equal(journal_add_job(jn, &polar, &err), 0);
    journal_close(&jn);
    assert_int_equal(testutil_journal_query(dir, "SELECT polarized FROM jobs WHERE id=9"), 2);
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    assert_int_equal(sqlite3_exec(db,
                                  "ALTER TABLE jobs DROP COLUMN polarized; UPDATE meta SET "
                                  "value=10 WHERE key='version'",
                                  NULL, NULL, NULL),
                     SQLITE_OK);
    sqlite3_close(db);
    assert_non_null(jn = journal_open(dir, &err));
    assert_int_equal(journal_jobs(jn, &rows, &n, &err), 0);
    assert_int_equal(n, 3);
    for (size_t i = 0; i < n; i++) {
        assert_int_equal(rows[i].settings.polarized, 0);
        journal_job_clear(&rows[i]);
    }
    free(rows);
    journal_close(&jn);
    assert_int_equal(testutil_journal_query(dir, "SELECT value FROM meta WHERE key='version'"),
                     JOURNAL_VERSION);

    /* A journal of another version is refused with a message, not reused. */
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    assert_int_equal(sqlite3_exec(db, "UPDATE meta SET value=99 WHERE key='version'", NULL, NULL, NULL),
                     SQLITE_OK);
    sqlite3_close(db);
    assert_null(journal_open(dir, &err));
    assert_non_null(strstr(err.msg, "version 99"));
    /* Not a database at all. */
    assert_int_equal(mkdir(testutil_scratch("junk"), 0755), 0);
    FILE *f = fopen(testutil_scratch("junk/journal.db"), "w");
    fputs("this is not an SQLite file, it is a text file of some length...........", f);
    fclose(f);
    assert_null(journal_open(testutil_scratch("junk"), &err));
    assert_non_null(strstr(err.msg, "junk/journal.db"));
}

/* One transaction per loop turn (journal_turn_begin/end, issue 17): the turn's results are not
 * in the database another process reads until the turn ends, or until a write of another kind
 * commits them first (so that a job's state never lands before the results that came before
 * it); the turn is one write in journal_stats; a checkpoint inside a turn still works (its
 * synchronous setting cannot change inside a transaction). */
static void test_turn_transaction(void **state)
{
    (void)state;
    err_t err;
    const char *dir = testutil_scratch("turns");
    journal_t *jn = journal_open(dir, &err);
    assert_non_null(jn);
    journal_job_t job = {.id = 3, .name = "t", .hash = "cd34", .main = "s.pbrt",
                         .settings = {.spp = 4, .seed = -1}};
    assert_int_equal(journal_add_job(jn, &job, &err), 0);
    const char *count = "SELECT COUNT(*) FROM results WHERE job=3";
    const uint8_t blob[4] = {1, 2, 3, 4};
    uint64_t writes = journal_stats(jn).writes;
    journal_turn_begin(jn);
    for (uint32_t t = 0; t < 3; t++)
        assert_int_equal(journal_add_result(jn, 3, 0, t, 0, (int)t, 0, blob, 4, &err), 0);
    assert_int_equal(testutil_journal_query(dir, count), 0);
    journal_job_t running = job;
    running.state = 1;
    assert_int_equal(journal_set_state(jn, &running, &err), 0);
    assert_int_equal(testutil_journal_query(dir, count), 3);
    assert_int_equal(testutil_journal_query(dir, "SELECT state FROM jobs WHERE id=3"), 1);
    for (uint32_t t = 3; t < 5; t++)
        assert_int_equal(journal_add_result(jn, 3, 0, t, 0, (int)t, 0, blob, 4, &err), 0);
    assert_int_equal(testutil_journal_query(dir, count), 3);
    int next[5] = {1, 1, 0, 0, 0};
    assert_int_equal(journal_set_checkpoint(jn, 3, 0, 1, next, 5, 1.0, &err), 0);
    assert_int_equal(testutil_journal_query(dir, count), 3); /* tiles 0 and 1 checkpointed */
    assert_int_equal(journal_add_result(jn, 3, 0, 5, 0, 0, 1, blob, 4, &err), 0);
    assert_int_equal(testutil_journal_query(dir, count), 3);
    assert_int_equal(journal_turn_end(jn, &err), 0);
    assert_int_equal(testutil_journal_query(dir, count), 4);
    /* Two result commits (before the state, before the checkpoint), the state, the checkpoint
     * and the turn's end: five writes for six results and two other changes. */
    assert_int_equal(journal_stats(jn).writes - writes, 5);
    /* Outside a turn each result is committed at once. */
    assert_int_equal(journal_add_result(jn, 3, 0, 6, 0, 1, 1, blob, 4, &err), 0);
    assert_int_equal(testutil_journal_query(dir, count), 5);

    /* A job added, a job's control set and a worker blocked in a turn whose results opened
     * its transaction are committed when their function returns (journal.h), with the results
     * before them: a master that died before the turn's end loses none of what it answered. */
    journal_turn_begin(jn);
    assert_int_equal(journal_add_result(jn, 3, 0, 7, 0, 2, 1, blob, 4, &err), 0);
    journal_job_t other = {.id = 4, .name = "u", .hash = "ef56", .main = "s.pbrt",
                           .settings = {.spp = 4, .seed = -1}};
    assert_int_equal(journal_add_job(jn, &other, &err), 0);
    assert_int_equal(testutil_journal_query(dir, "SELECT COUNT(*) FROM jobs WHERE id=4"), 1);
    assert_int_equal(testutil_journal_query(dir, count), 6);
    assert_int_equal(journal_add_result(jn, 3, 0, 8, 0, 3, 1, blob, 4, &err), 0);
    assert_int_equal(journal_set_control(jn, 4, 7, true, &err), 0);
    assert_int_equal(testutil_journal_query(dir, "SELECT priority FROM jobs WHERE id=4"), 7);
    assert_int_equal(testutil_journal_query(dir, count), 7);
    assert_int_equal(journal_add_result(jn, 3, 0, 9, 0, 4, 1, blob, 4, &err), 0);
    assert_int_equal(journal_set_blocked(jn, "node07", "3 failures", &err), 0);
    assert_int_equal(testutil_journal_query(dir, "SELECT COUNT(*) FROM blocked"), 1);
    assert_int_equal(testutil_journal_query(dir, count), 8);
    assert_int_equal(journal_turn_end(jn, &err), 0);
    journal_close(&jn);
}

/* ---------------------------------------------------------------- farms */

/* The number after "key": in a command's --json text; false if the key is absent or null. */
static bool json_number(const char *json, const char *key, double *v)
{
    char k[64];
    snprintf(k, sizeof k, "\"%s\":", key);
    const char *p = strstr(json, k);
    return p && sscanf(p + strlen(k), " %lf", v) == 1;
}

/* A master on spool with one worker, job 1 (scene at spp) submitted to it, and the journal
 * waited on until it holds a checkpoint and camera results after it: what the kill tests start
 * from. tag names the logs ("TAG-master1.log", "TAG-w.log"); wep and cep get the endpoints. */
typedef struct started {
    pid_t master, worker;
    char wep[256], cep[256];
} started_t;

static started_t start_until_checkpoint(const char *scene, const char *spp, const char *spool,
                                        const char *tag)
{
    started_t st;
    char name[64];
    snprintf(name, sizeof name, "%s-master1.log", tag);
    const char *mlog = testutil_scratch(name);
    st.master = testutil_journal_master(mlog, spool, "tcp://127.0.0.1:*", "tcp://127.0.0.1:*");
    testutil_read_endpoints(spool, st.wep, st.cep, mlog);
    snprintf(name, sizeof name, "%s-w.log", tag);
    st.worker = testutil_journal_worker(testutil_scratch(name), st.wep, "w");
    const run_t *r = run("submit", scene, "--master", st.cep, "--spp", spp, "--insecure", NULL);
    if (r->status != 0)
        fail_msg("submit: exit %d: %s", r->status, r->err);
    assert_string_equal(r->out, "1\n");
    testutil_wait_journal(spool, test_wait_s(), "a checkpoint and results after it",
                          "SELECT checkpoint FROM jobs WHERE id=1",
                          "SELECT COUNT(*) FROM results WHERE job=1 AND kind=0", NULL);
    return st;
}

/* A camera job whose master dies after a checkpoint, with results journaled after it: the
 * restarted master restores the checkpoint, merges those results again and finishes with the
 * pixels of an uninterrupted render. */
static void test_master_killed_camera_job(void **state)
{
    (void)state;
    const char *ref = testutil_journal_reference(SCENE, SPP, "tiny-ref.exr");
    const char *spool = testutil_scratch("cam-spool"), *mlog2 = testutil_scratch("cam-master2.log");
    started_t job = start_until_checkpoint(SCENE, SPP, spool, "cam");
    pid_t master = job.master, w = job.worker;
    const char *wep = job.wep, *cep = job.cep;
    testutil_stop(master, SIGKILL);
    long long ckpt = testutil_journal_query(spool, "SELECT checkpoint FROM jobs WHERE id=1");
    long long kept = testutil_journal_query(spool, "SELECT COUNT(*) FROM results WHERE job=1");
    print_message("master killed at checkpoint %lld with %lld results journaled after it\n", ckpt,
                  kept);

    master = testutil_journal_master(mlog2, spool, wep, cep);
    testutil_journal_finish(cep, ref, testutil_scratch("cam-out.exr"), mlog2);
    char *log = testutil_slurp(mlog2, NULL);
    const char *resumed = log ? strstr(log, "job 1 'tiny' resumed: ") : NULL;
    if (!resumed) {
        free(log);
        testutil_fail_quoting(mlog2, "the restarted master did not resume job 1:");
    }
    int done, passes;
    size_t replayed;
    assert_int_equal(sscanf(resumed, "job 1 'tiny' resumed: %d of %d passes merged", &done, &passes),
                     2);
    assert_non_null(strstr(resumed, "results from the journal"));
    assert_true(sscanf(strstr(resumed, "batches, ") + 9, "%zu", &replayed) == 1);
    /* The checkpoint held passes, and the results after it were merged again, not rendered. */
    assert_true(done >= 1);
    assert_int_equal((long long)replayed, kept);
    free(log);
    /* A finished job leaves neither results nor checkpoint files behind. */
    assert_int_equal(testutil_journal_query(spool, "SELECT COUNT(*) FROM results"), 0);
    assert_int_equal(testutil_journal_query(spool, "SELECT state FROM jobs WHERE id=1"), 2);
    char ck[700];
    snprintf(ck, sizeof ck, "%s/jobs/1/checkpoint-%lld.bin", spool, ckpt);
    struct stat st;
    assert_int_equal(stat(ck, &st), -1);
    /* A master started once more lists the finished job as it was: the time it ran and its
     * last error estimate come from the journal. */
    const run_t *before = run("status", "1", "--json", "--master", cep, "--insecure", NULL);
    assert_int_equal(before->status, 0);
    double el0 = 0, re0 = 0, el1 = 0, re1 = 0;
    assert_true(json_number(before->out, "elapsed_s", &el0));
    assert_true(json_number(before->out, "rel_error", &re0));
    testutil_stop(master, SIGTERM);
    master = testutil_journal_master(testutil_scratch("cam-master3.log"), spool, wep, cep);
    const run_t *after = run("status", "1", "--json", "--master", cep, "--insecure", NULL);
    if (after->status != 0)
        fail_msg("status 1 after the restart: exit %d: %s", after->status, after->err);
    if (!json_number(after->out, "elapsed_s", &el1) || !json_number(after->out, "rel_error", &re1))
        fail_msg("the restarted master lost the finished job's figures:\n%s", after->out);
    assert_true(el0 > 0 && el1 > 0);
    assert_true(fabs(el1 - el0) <= 0.01 * el0 + 1e-3);
    assert_true(re1 == re0);
    testutil_stop(w, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* A spool left by a master of journal version 8, whose result blobs were journal_blobs.c's
 * packed tiles rather than the RESULT messages received: the journal of a killed camera job is
 * rewritten into that form (each blob decoded and packed again into a new segment, the rows
 * pointed at it, the version set to 8), and a master of this version resumes it with the
 * pixels of an uninterrupted render, merging those blobs, not rendering their tasks again. The
 * job has a Stokes output (four planes per bucket in every result, checkpoint and blob), so the
 * comparison covers its S0-S3 layers too (testutil_assert_same_pixels). */
static void test_version8_spool_resumes(void **state)
{
    (void)state;
    const char *ref = testutil_journal_reference(STOKES_SCENE, SPP, "stokes-ref.exr");
    const char *spool = testutil_scratch("v8-spool"), *mlog2 = testutil_scratch("v8-master2.log");
    started_t job = start_until_checkpoint(STOKES_SCENE, SPP, spool, "v8");
    pid_t master = job.master, w = job.worker;
    const char *wep = job.wep, *cep = job.cep;
    testutil_stop(w, SIGKILL);
    testutil_stop(master, SIGKILL);

    char path[700];
    snprintf(path, sizeof path, "%s/journal.db", spool);
    sqlite3 *db;
    assert_int_equal(sqlite3_open(path, &db), SQLITE_OK);
    sqlite3_stmt *st;
    assert_int_equal(sqlite3_prepare_v2(db,
                                        "SELECT round, task, size, seg, offset FROM results "
                                        "WHERE job=1 AND kind=0",
                                        -1, &st, NULL),
                     SQLITE_OK);
    const uint32_t newseg = 999;
    char segpath[760];
    snprintf(segpath, sizeof segpath, "%s/results/1/%u.log", spool, newseg);
    FILE *out = fopen(segpath, "wb");
    assert_non_null(out);
    /* Room for one UPDATE per result (at most 200 bytes each). */
    size_t cap = 256 + 200 * (size_t)testutil_journal_query(
                                 spool, "SELECT COUNT(*) FROM results WHERE job=1 AND kind=0");
    char *sql = malloc(cap);
    assert_non_null(sql);
    size_t rewritten = 0, k = (size_t)snprintf(sql, cap, "BEGIN;");
    long long offset = 0;
    while (sqlite3_step(st) == SQLITE_ROW) {
        long long round = sqlite3_column_int64(st, 0), task = sqlite3_column_int64(st, 1),
                  size = sqlite3_column_int64(st, 2), seg = sqlite3_column_int64(st, 3),
                  off = sqlite3_column_int64(st, 4);
        char from[760];
        snprintf(from, sizeof from, "%s/results/1/%lld.log", spool, seg);
        size_t len;
        char *bytes = testutil_slurp(from, &len);
        assert_non_null(bytes);
        assert_true(off + size <= (long long)len);
        proto_msg_t msg;
        err_t err;
        if (proto_decode(bytes + off, (size_t)size, NULL, &msg, &err) < 0)
            fail_msg("a version-9 blob is not a RESULT message: %s", err.msg);
        assert_int_equal(msg.type, PROTO_RESULT);
        uint8_t *blob;
        size_t bsize;
        assert_int_equal(journal_pack_tile(&msg.result.tile, &blob, &bsize, &err), 0);
        assert_true(journal_blob_is_v8(blob, bsize));
        assert_int_equal(fwrite(blob, 1, bsize, out), bsize);
        k += (size_t)snprintf(sql + k, cap - k,
                              "UPDATE results SET seg=%u, offset=%lld, size=%zu, crc=%lu WHERE "
                              "job=1 AND round=%lld AND task=%lld;",
                              newseg, offset, bsize, crc32(crc32(0L, Z_NULL, 0), blob, (uInt)bsize),
                              round, task);
        assert_true(k < cap - 200);
        offset += (long long)bsize;
        rewritten++;
        free(blob);
        proto_msg_free(&msg);
        free(bytes);
    }
    sqlite3_finalize(st);
    assert_int_equal(fclose(out), 0);
    snprintf(sql + k, cap - k, "UPDATE meta SET value=8 WHERE key='version'; COMMIT;");
    assert_int_equal(sqlite3_exec(db, sql, NULL, NULL, NULL), SQLITE_OK);
    free(sql);
    sqlite3_close(db);
    assert_true(rewritten > 0);
    print_message("%zu results rewritten as version-8 blobs\n", rewritten);

    master = testutil_journal_master(mlog2, spool, wep, cep);
    w = testutil_journal_worker(testutil_scratch("v8-w2.log"), wep, "w");
    testutil_journal_finish(cep, ref, testutil_scratch("v8-out.exr"), mlog2);
    char *log = testutil_slurp(mlog2, NULL);
    const char *resumed = log ? strstr(log, "job 1 'stokes' resumed: ") : NULL;
    size_t replayed = 0;
    if (!resumed || !strstr(resumed, "batches, ") ||
        sscanf(strstr(resumed, "batches, ") + 9, "%zu", &replayed) != 1) {
        free(log);
        testutil_fail_quoting(mlog2, "the restarted master did not resume job 1:");
    }
    assert_int_equal(replayed, rewritten);
    free(log);
    err_t err;
    image_exr_t *img = image_exr_read(ref, &err);
    if (!img)
        fail_msg("%s", err.msg);
    assert_non_null(image_exr_stokes(img, 3)); /* the comparison covered the Stokes layers */
    image_exr_destroy(&img);
    testutil_stop(w, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* A photon job whose master dies twice: during the photon phase (batches journaled, no store
 * yet) and during the camera phase (the store on disk): the same pixels as one machine's. */
static void test_master_killed_photon_job(void **state)
{
    (void)state;
    const char *ref = testutil_journal_reference(PHOTON_SCENE, PHOTON_SPP, "beam-ref.exr");
    const char *spool = testutil_scratch("ph-spool"), *mlog1 = testutil_scratch("ph-master1.log"),
               *mlog2 = testutil_scratch("ph-master2.log"),
               *mlog3 = testutil_scratch("ph-master3.log");
    pid_t master = testutil_journal_master(mlog1, spool, "tcp://127.0.0.1:*", "tcp://127.0.0.1:*");
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog1);
    pid_t w1 = testutil_journal_worker(testutil_scratch("ph-w1.log"), wep, "w1");
    pid_t w2 = testutil_journal_worker(testutil_scratch("ph-w2.log"), wep, "w2");
    const run_t *r = run("submit", PHOTON_SCENE, "--master", cep, "--spp", PHOTON_SPP,
                         "--insecure", NULL);
    if (r->status != 0)
        fail_msg("submit: exit %d: %s", r->status, r->err);
    testutil_wait_journal(spool, test_wait_s(), "a photon batch",
                 "SELECT COUNT(*) FROM results WHERE kind=1", NULL);
    testutil_stop(master, SIGKILL);
    long long batches = testutil_journal_query(spool, "SELECT COUNT(*) FROM results WHERE kind=1");
    long long saved = testutil_journal_query(spool, "SELECT photons_saved FROM jobs WHERE id=1");
    print_message("master killed with %lld photon batches journaled, store saved: %lld\n",
                  batches, saved);

    master = testutil_journal_master(mlog2, spool, wep, cep);
    testutil_wait_journal(spool, 1.5 * test_wait_s(), "the photon store and camera results",
                 "SELECT photons_saved FROM jobs WHERE id=1",
                 "SELECT COUNT(*) FROM results WHERE job=1 AND kind=0", NULL);
    testutil_stop(master, SIGKILL);
    if (!testutil_file_has(mlog2, "job 1 'beam_big' resumed: "))
        testutil_fail_quoting(mlog2, "the second master did not resume job 1:");
    if (saved == 0 && !testutil_file_has(mlog2, "photon batches, "))
        testutil_fail_quoting(mlog2, "no photon batches replayed:");

    master = testutil_journal_master(mlog3, spool, wep, cep);
    testutil_journal_finish(cep, ref, testutil_scratch("ph-out.exr"), mlog3);
    /* The third master took the photon store from disk: no photon batch was traced again. */
    char *log3 = testutil_slurp(mlog3, NULL);
    assert_non_null(log3);
    const char *resumed = strstr(log3, "job 1 'beam_big' resumed: ");
    assert_non_null(resumed);
    unsigned bd, bt;
    const char *b = strstr(resumed, "samples, ");
    assert_non_null(b);
    assert_int_equal(sscanf(b, "samples, %u of %u photon batches", &bd, &bt), 2);
    assert_int_equal(bd, bt);
    free(log3);
    testutil_stop(w1, SIGTERM);
    testutil_stop(w2, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* The master, the workers and the client killed (SIGKILL) at seeded random moments while a job
 * renders, each started again after a short random pause; the job ends with the pixels of an
 * uninterrupted render. PRISMFARM_KILL_SEED picks another schedule. The moments are tied to the
 * job's progress as the journal records it, not to the clock, so that the kills fall while the
 * job runs on a machine of any speed: kill i waits until at least at_pass[i] of the job's
 * NPASSES_LONG passes are journaled, then a random pause. Passes double in samples, so after
 * pass p the job has 2^(p - NPASSES_LONG) of its samples: the first three kills (one of each
 * kind) wait for passes NPASSES_LONG - 10 to NPASSES_LONG - 7, with 127/128 of the job or more
 * still to render; the others for up to pass NPASSES_LONG - 2, and only while the job runs. */
static void test_random_kills(void **state)
{
    (void)state;
    /* Kept in buffers of their own: the loop below takes more paths from testutil_scratch than
     * its rotating buffers hold. */
    char ref[512], spool[512];
    snprintf(ref, sizeof ref, "%s", testutil_journal_reference(SCENE, SPP_LONG, "tiny-long-ref.exr"));
    snprintf(spool, sizeof spool, "%s", testutil_scratch("rk-spool"));
    const char *env = getenv("PRISMFARM_KILL_SEED");
    uint64_t seed = env ? strtoull(env, NULL, 10) : 20261125;
    rng_stream_t rng = rng_stream_make(seed, 0, 0);
    char mlog[64];
    int nmaster = 1, nworker = 0, nclient = 1;
    snprintf(mlog, sizeof mlog, "rk-master%d.log", nmaster);
    pid_t master =
        testutil_journal_master(testutil_scratch(mlog), spool, "tcp://127.0.0.1:*", "tcp://127.0.0.1:*");
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch(mlog));
    pid_t workers[2];
    for (int i = 0; i < 2; i++) {
        char log[64], name[8];
        snprintf(log, sizeof log, "rk-w%d-%d.log", i, nworker++);
        snprintf(name, sizeof name, "w%d", i);
        workers[i] = testutil_journal_worker(testutil_scratch(log), wep, name);
    }
    pid_t client = testutil_spawn(testutil_scratch("rk-client1.log"), "submit", SCENE, "--master",
                                  cep, "--spp", SPP_LONG, "--wait", "--quiet", "--insecure", "-o",
                                  testutil_scratch("rk-client.exr"), NULL);
    testutil_wait_journal(spool, test_wait_s(), "the job", "SELECT COUNT(*) FROM jobs", NULL);
    /* Each of master, worker and client once in a shuffled order, then random ones: at most
     * eight kills, none after the job is done. */
    int order[8] = {0, 1, 2}, at_pass[8];
    for (int i = 2; i > 0; i--) {
        int k = (int)(rng_stream_next(&rng) * (i + 1)), t = order[i];
        order[i] = order[k];
        order[k] = t;
    }
    for (int i = 3; i < 8; i++)
        order[i] = (int)(rng_stream_next(&rng) * 3);
    for (int i = 0; i < 8; i++) {
        at_pass[i] = NPASSES_LONG - (i < 3 ? 10 : 6) + (int)(rng_stream_next(&rng) * 4);
        if (i > 0 && at_pass[i] < at_pass[i - 1])
            at_pass[i] = at_pass[i - 1];
    }
    int kills = 0;
    for (int i = 0; i < 8; i++) {
        int done = 0;
        for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(20)) {
            done = testutil_journal_query(spool, "SELECT state FROM jobs WHERE id=1") >= 2;
            if (done ||
                testutil_journal_query(spool, "SELECT MAX(pass) FROM passes WHERE job=1") >= at_pass[i])
                break;
            if (testutil_now_s() > until)
                fail_msg("seed %llu: pass %d of job 1 not journaled after %.0f s",
                         (unsigned long long)seed, at_pass[i], test_wait_s());
        }
        if (!done) {
            testutil_sleep_ms((int)(rng_stream_next(&rng) * 100));
            done = testutil_journal_query(spool, "SELECT state FROM jobs WHERE id=1") >= 2;
        }
        if (done) {
            if (i < 3)
                fail_msg("seed %llu: job 1 ended before kill %d (at pass %d)",
                         (unsigned long long)seed, i + 1, at_pass[i]);
            break;
        }
        int pause = (int)(rng_stream_next(&rng) * 300);
        if (order[i] == 0) {
            testutil_stop(master, SIGKILL);
            testutil_sleep_ms(pause);
            snprintf(mlog, sizeof mlog, "rk-master%d.log", ++nmaster);
            master = testutil_journal_master(testutil_scratch(mlog), spool, wep, cep);
        } else if (order[i] == 1) {
            int k = rng_stream_next(&rng) < 0.5 ? 0 : 1;
            testutil_stop(workers[k], SIGKILL);
            testutil_sleep_ms(pause);
            char log[64], name[8];
            snprintf(log, sizeof log, "rk-w%d-%d.log", k, nworker++);
            snprintf(name, sizeof name, "w%d", k);
            workers[k] = testutil_journal_worker(testutil_scratch(log), wep, name);
        } else {
            testutil_stop(client, SIGKILL);
            testutil_sleep_ms(pause);
            char log[64];
            snprintf(log, sizeof log, "rk-client%d.log", ++nclient);
            client = testutil_spawn(testutil_scratch(log), "status", "1", "--wait", "--quiet",
                                    "--master", cep, "--insecure", NULL);
        }
        kills++;
        print_message("seed %llu: kill %d at pass %d: %s\n", (unsigned long long)seed, kills,
                      at_pass[i], order[i] == 0 ? "master" : order[i] == 1 ? "worker" : "client");
    }
    print_message("seed %llu: %d kills (%d masters, %d worker starts, %d clients)\n",
                  (unsigned long long)seed, kills, nmaster, nworker, nclient);
    /* Every kind was killed at least once before the job ended (the job is long enough). */
    assert_true(kills >= 3);
    testutil_journal_finish(cep, ref, testutil_scratch("rk-out.exr"), testutil_scratch(mlog));
    /* The last client follows the job to its end by itself through any restarts. */
    int st = testutil_stop(client, 0);
    assert_true(WIFEXITED(st));
    if (WEXITSTATUS(st) != 0)
        testutil_fail_quoting(testutil_scratch("rk-client1.log"),
                              "the last client exited %d:", WEXITSTATUS(st));
    for (int i = 0; i < 2; i++)
        testutil_stop(workers[i], SIGTERM);
    testutil_stop(master, SIGTERM);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tile_blob_round_trip),
        cmocka_unit_test(test_photon_blob_round_trip),
        cmocka_unit_test(test_checkpoint_round_trip),
        cmocka_unit_test(test_journal_tables),
        cmocka_unit_test(test_turn_transaction),
        cmocka_unit_test_teardown(test_master_killed_camera_job, testutil_kill_children),
        cmocka_unit_test_teardown(test_version8_spool_resumes, testutil_kill_children),
        cmocka_unit_test_teardown(test_master_killed_photon_job, testutil_kill_children),
        cmocka_unit_test_teardown(test_random_kills, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
