/* proto: every message type survives encode -> decode bit for bit; a peer of another version is
 * refused with a readable reason; and a gallery of malformed and hostile inputs (truncation at
 * every byte, lying container headers, deep nesting, wrong types, oversize bins, NaN, bad bundle
 * paths, trailing bytes, random mutations) is rejected with an error naming the field, never a
 * crash or a leak (the sanitizer build checks both). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers it needs */

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bundle.h"
#include "proto.h"
#include "sha256.h"
#include "tilebuf.h"

#if defined(__SSE__)
#include <pmmintrin.h>
#endif

/* ---------------------------------------------------------------- sample messages */

enum { RW = 5, RH = 3, RNB = 4, RPIX = RW * RH };

static double g_sums[RPIX * RNB], g_xyz[RPIX * PROTO_TILE_XYZ], g_lum[RPIX], g_lum_sq[RPIX];
static uint64_t g_counts[RPIX];

static const uint8_t g_ply[] = {'p', 'l', 'y', '\n', 0, 1, 2, 0xff, 0xfe, 0};
static const char g_scene_text[] = "Film \"spectral\"\nShape \"plymesh\" \"string filename\" "
                                   "\"meshes/prism.ply\"\n";
static const proto_bundle_file_t g_files[] = {
    {"scene.pbrt", (const uint8_t *)g_scene_text, sizeof g_scene_text - 1},
    {"meshes/prism.ply", g_ply, sizeof g_ply},
    {"textures/empty.png", NULL, 0},
};
static const proto_bundle_t g_bundle = {"scene.pbrt", g_files, 3};
static char g_hash[PROTO_HASH_HEX + 1];

static const proto_job_info_t g_jobs[] = {
    /* running, 4 spp merged, an estimate of 1/16 (exact in binary), a photon pass at 12000 of
     * 30000 photons */
    {1, "prism", JOB_RUNNING, 1000, 65536, 12.5, NULL, 3, 4, true, 0.0625, PROTO_STOP_NONE, "alice",
     -1000, 0, 0, 0, 12000, 30000},
    {2, "gem fire", JOB_FAILED, 7, 100, 0.0, "worker w1: scene.pbrt:3: unknown shape", 0, 0, false,
     0, PROTO_STOP_NONE, NULL, 0, 0, 0, 0, 0, 0},
    {UINT64_MAX, "x", JOB_CANCELLED, 0, 0, 1e9, NULL, UINT64_MAX, 0, false, 0, PROTO_STOP_NONE,
     NULL, 0, 0, 0, 0, 0, 0},
    /* done early: 64 of 1024 spp reached the target; an estimate of exactly 0 travels too */
    {4, "prism fast", JOB_DONE, 64 * 96, 1024 * 96, 0.75, NULL, 0, 64, true, 0.0, PROTO_STOP_TARGET,
     "bob", 3, 0, 0, 0, 0, 0},
};
/* A frame sequence (job 5, two frames) and its frames 6 and 7, numbered 0 and 120. */
static const proto_job_info_t g_sequence[] = {
    {5, "walk", JOB_RUNNING, 10, 200, 1.0, NULL, 0, 0, false, 0, PROTO_STOP_NONE, NULL, 0, 2, 0, 0,
     0, 0},
    {6, "walk0000", JOB_DONE, 100, 100, 1.0, NULL, 0, 16, false, 0, PROTO_STOP_NONE, NULL, 0, 0, 5,
     0, 0, 0},
    {7, "walk0120", JOB_RUNNING, 10, 100, 1.0, NULL, 0, 1, false, 0, PROTO_STOP_NONE, NULL, 0, 0, 5,
     120, 0, 0},
};
static const proto_frame_t g_frames[] = {{"scene.pbrt", 0}, {"meshes/prism.ply", 120}};
static const proto_worker_info_t g_workers[] = {
    {"node01", 7, 64, PROTO_WORKER_BUSY, 1234, 0.25, 0, 0, 0, 0},
    {"node02", 8, 1, PROTO_WORKER_LOST, 0, 31.0, 0, 0, 0, 0},
    {"node03", 9, 4, PROTO_WORKER_BLOCKED, 3, 0.5, 12, 5, 2, 1.5e6},
};
static const uint8_t g_png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0};

static void fill_arrays(void)
{
    for (int i = 0; i < RPIX * RNB; i++)
        g_sums[i] = (i - 30) * 0.1 + 1.0 / 3.0;
    /* Values whose bits a careless encoding would change: negative zero, a subnormal, the
     * extremes, and 1/3 (not representable exactly in decimal). */
    g_sums[0] = -0.0;
    g_sums[1] = DBL_MIN / 4;
    g_sums[2] = DBL_MAX;
    g_sums[3] = -DBL_MAX;
    g_sums[4] = 1.0 / 3.0;
    /* XYZ sums that are float values, so that the sums alone decide the width picked. */
    for (int i = 0; i < RPIX * PROTO_TILE_XYZ; i++)
        g_xyz[i] = 0.25 * i - 3.0;
    for (int i = 0; i < RPIX; i++) {
        g_counts[i] = (uint64_t)i * 1000003u;
        g_lum[i] = 0.5 * i;
        g_lum_sq[i] = 0.25 * i * i;
    }
    g_counts[0] = UINT64_MAX;
    g_counts[1] = (UINT64_C(1) << 53) + 1; /* not representable as a double */
    err_t err;
    assert_int_equal(proto_bundle_hash(&g_bundle, g_hash, &err), 0);
}

static const proto_settings_t g_settings = {256, 640, 480, 42, "path", "fanout", 0.01, 90.5, 0, 2};

static proto_msg_t sample(proto_type_t t)
{
    proto_msg_t m = {.type = t};
    switch (t) {
    case PROTO_HELLO:
        m.hello.name = "node01";
        m.hello.threads = 64;
        m.hello.software = "prismfarm 0.1.0";
        break;
    case PROTO_WELCOME:
        m.welcome.worker_id = 0x123456789abcULL;
        m.welcome.heartbeat_ms = 1000;
        break;
    case PROTO_TASK:
        m.task.job = 17;
        m.task.task = 4242;
        m.task.attempt = 2;
        memcpy(m.task.scene, g_hash, sizeof g_hash);
        m.task.settings = (proto_settings_t){0, 0, 0, -1, NULL, NULL, 0, 0, 0, 0}; /* all "keep" */
        m.task.kind = PROTO_KIND_CAMERA_TILE;
        m.task.tile = (proto_tile_t){64, 32, 32, 32, 100, 164};
        break;
    case PROTO_RESULT:
        m.result.job = 17;
        m.result.task = 4242;
        m.result.attempt = 2;
        m.result.kind = PROTO_KIND_CAMERA_TILE;
        m.result.tile = (proto_tile_result_t){.rect = {10, 20, RW, RH, 0, 64},
                                              .nbuckets = RNB,
                                              .sums = g_sums,
                                              .xyz = g_xyz,
                                              .counts = g_counts,
                                              .lum = g_lum,
                                              .lum_sq = g_lum_sq,
                                              .nonfinite = 5};
        m.result.stats = (proto_task_stats_t){960, 123456789, 77, 0.125};
        break;
    case PROTO_TASK_FAILED:
        m.task_failed.job = 17;
        m.task_failed.task = 4242;
        m.task_failed.attempt = 3;
        m.task_failed.error = "scene.pbrt:3:7: unknown shape \"torus\"\n(second line)";
        break;
    case PROTO_SCENE_REQUEST:
        memcpy(m.scene_request.scene, g_hash, sizeof g_hash);
        break;
    case PROTO_SCENE:
        memcpy(m.scene.scene, g_hash, sizeof g_hash);
        m.scene.bundle = g_bundle;
        break;
    case PROTO_CANCEL:
        m.cancel.job = 99;
        break;
    case PROTO_REFUSE:
        m.refuse.reason = "go away";
        break;
    case PROTO_SUBMIT:
        m.submit.name = "prism";
        m.submit.settings = g_settings;
        m.submit.bundle = g_bundle;
        break;
    case PROTO_STATUS:
        m.status.all = false;
        m.status.job = 5;
        break;
    case PROTO_FETCH:
        m.fetch.job = 5;
        m.fetch.what = PROTO_FETCH_PNG;
        break;
    case PROTO_SUBMITTED:
        m.submitted.job = 5;
        break;
    case PROTO_STATUS_REPLY:
        m.status_reply.jobs = g_jobs;
        m.status_reply.njobs = 1;
        break;
    case PROTO_JOBS_REPLY:
        m.jobs_reply.jobs = g_jobs;
        m.jobs_reply.njobs = 4;
        break;
    case PROTO_WORKERS_REPLY:
        m.workers_reply.workers = g_workers;
        m.workers_reply.nworkers = 3;
        break;
    case PROTO_FILE:
        m.file.name = "prism.png";
        m.file.data = g_png;
        m.file.size = sizeof g_png;
        break;
    case PROTO_ERROR:
        m.error.message = "job 5 not found";
        break;
    case PROTO_STORE_REQUEST:
        memcpy(m.store_request.store, g_hash, sizeof g_hash);
        break;
    case PROTO_REFINE:
        m.refine.job = 12;
        m.refine.photons = 5000000;
        break;
    case PROTO_PROGRESS:
        m.progress.message = "the master is loading the scene (4 s so far)";
        m.progress.elapsed = 4.25;
        break;
    case PROTO_ACT:
        m.act.act = PROTO_ACT_PRIORITY;
        m.act.job = 12;
        m.act.priority = -7;
        break;
    case PROTO_LOGS:
        m.logs.job = 12;
        m.logs.has_task = true;
        m.logs.task = 0;
        break;
    case PROTO_STORE:
        m.store.data = g_png;
        m.store.size = sizeof g_png;
        sha256_hex_of(g_png, sizeof g_png, m.store.store);
        break;
    default:
        break;
    }
    return m;
}

/* ---------------------------------------------------------------- comparisons */

static void assert_opt_string_equal(const char *a, const char *b)
{
    if (!a || !b)
        assert_ptr_equal(a, b);
    else
        assert_string_equal(a, b);
}

static void assert_words_equal(const void *a, const void *b, size_t n)
{
    assert_non_null(a);
    assert_non_null(b);
    assert_memory_equal(a, b, n * 8);
}

static void assert_bundle_equal(const proto_bundle_t *a, const proto_bundle_t *b)
{
    assert_string_equal(a->main, b->main);
    assert_int_equal(a->nfiles, b->nfiles);
    for (size_t i = 0; i < a->nfiles; i++) {
        assert_string_equal(a->files[i].path, b->files[i].path);
        assert_int_equal(a->files[i].size, b->files[i].size);
        if (a->files[i].size)
            assert_memory_equal(a->files[i].data, b->files[i].data, a->files[i].size);
    }
}

static void assert_settings_equal(const proto_settings_t *a, const proto_settings_t *b)
{
    assert_int_equal(a->spp, b->spp);
    assert_int_equal(a->xres, b->xres);
    assert_int_equal(a->yres, b->yres);
    assert_int_equal(a->seed, b->seed);
    assert_opt_string_equal(a->integrator, b->integrator);
    assert_opt_string_equal(a->dispersion, b->dispersion);
    assert_true(a->target_error == b->target_error);
    assert_true(a->time_limit == b->time_limit);
}

static void assert_tile_equal(const proto_tile_t *a, const proto_tile_t *b)
{
    assert_int_equal(a->x0, b->x0);
    assert_int_equal(a->y0, b->y0);
    assert_int_equal(a->w, b->w);
    assert_int_equal(a->h, b->h);
    assert_int_equal(a->sample_begin, b->sample_begin);
    assert_int_equal(a->sample_end, b->sample_end);
}

static void assert_msg_equal(const proto_msg_t *a, const proto_msg_t *b)
{
    assert_int_equal(a->type, b->type);
    switch (a->type) {
    case PROTO_HELLO:
        assert_string_equal(a->hello.name, b->hello.name);
        assert_int_equal(a->hello.threads, b->hello.threads);
        assert_string_equal(a->hello.software, b->hello.software);
        break;
    case PROTO_WELCOME:
        assert_int_equal(a->welcome.worker_id, b->welcome.worker_id);
        assert_int_equal(a->welcome.heartbeat_ms, b->welcome.heartbeat_ms);
        break;
    case PROTO_TASK:
        assert_int_equal(a->task.job, b->task.job);
        assert_int_equal(a->task.task, b->task.task);
        assert_int_equal(a->task.attempt, b->task.attempt);
        assert_string_equal(a->task.scene, b->task.scene);
        assert_settings_equal(&a->task.settings, &b->task.settings);
        assert_int_equal(a->task.kind, b->task.kind);
        assert_string_equal(a->task.store, b->task.store);
        assert_opt_string_equal(a->task.main, b->task.main);
        if (a->task.kind == PROTO_KIND_PHOTON_BATCH) {
            assert_int_equal(a->task.photons.first, b->task.photons.first);
            assert_int_equal(a->task.photons.end, b->task.photons.end);
        } else {
            assert_tile_equal(&a->task.tile, &b->task.tile);
        }
        break;
    case PROTO_RESULT: {
        if (a->result.kind == PROTO_KIND_PHOTON_BATCH) {
            const proto_photon_result_t *x = &a->result.photons, *y = &b->result.photons;
            assert_int_equal(b->result.kind, PROTO_KIND_PHOTON_BATCH);
            assert_int_equal(a->result.job, b->result.job);
            assert_int_equal(x->range.first, y->range.first);
            assert_int_equal(x->range.end, y->range.end);
            assert_int_equal(x->emitted, y->emitted);
            assert_int_equal(x->nonfinite, y->nonfinite);
            assert_int_equal(x->size, y->size);
            assert_memory_equal(x->data, y->data, x->size);
            assert_int_equal(a->result.stats.samples, b->result.stats.samples);
            break;
        }
        const proto_tile_result_t *x = &a->result.tile, *y = &b->result.tile;
        size_t npix = (size_t)x->rect.w * (size_t)x->rect.h;
        assert_int_equal(a->result.job, b->result.job);
        assert_int_equal(a->result.task, b->result.task);
        assert_int_equal(a->result.attempt, b->result.attempt);
        assert_int_equal(a->result.kind, b->result.kind);
        assert_tile_equal(&x->rect, &y->rect);
        assert_int_equal(x->nbuckets, y->nbuckets);
        assert_words_equal(x->sums, y->sums, npix * (size_t)x->nbuckets);
        assert_words_equal(x->xyz, y->xyz, npix * PROTO_TILE_XYZ);
        assert_words_equal(x->counts, y->counts, npix);
        assert_words_equal(x->lum, y->lum, npix);
        assert_words_equal(x->lum_sq, y->lum_sq, npix);
        assert_int_equal(x->nonfinite, y->nonfinite);
        if (x->sums_bits) /* 0: the encoder picked */
            assert_int_equal(x->sums_bits, y->sums_bits);
        assert_int_equal(a->result.stats.samples, b->result.stats.samples);
        assert_int_equal(a->result.stats.rays, b->result.stats.rays);
        assert_int_equal(a->result.stats.dispersive, b->result.stats.dispersive);
        assert_memory_equal(&a->result.stats.elapsed, &b->result.stats.elapsed, sizeof(double));
        break;
    }
    case PROTO_TASK_FAILED:
        assert_int_equal(a->task_failed.job, b->task_failed.job);
        assert_int_equal(a->task_failed.task, b->task_failed.task);
        assert_int_equal(a->task_failed.attempt, b->task_failed.attempt);
        assert_string_equal(a->task_failed.error, b->task_failed.error);
        break;
    case PROTO_SCENE_REQUEST:
        assert_string_equal(a->scene_request.scene, b->scene_request.scene);
        break;
    case PROTO_SCENE:
        assert_string_equal(a->scene.scene, b->scene.scene);
        assert_bundle_equal(&a->scene.bundle, &b->scene.bundle);
        break;
    case PROTO_CANCEL:
        assert_int_equal(a->cancel.job, b->cancel.job);
        break;
    case PROTO_REFUSE:
        assert_string_equal(a->refuse.reason, b->refuse.reason);
        break;
    case PROTO_SUBMIT:
        assert_string_equal(a->submit.name, b->submit.name);
        assert_settings_equal(&a->submit.settings, &b->submit.settings);
        assert_bundle_equal(&a->submit.bundle, &b->submit.bundle);
        assert_int_equal(a->submit.nframes, b->submit.nframes);
        for (size_t i = 0; i < a->submit.nframes; i++) {
            assert_string_equal(a->submit.frames[i].main, b->submit.frames[i].main);
            assert_int_equal(a->submit.frames[i].number, b->submit.frames[i].number);
        }
        break;
    case PROTO_STATUS:
        assert_int_equal(a->status.all, b->status.all);
        if (!a->status.all)
            assert_int_equal(a->status.job, b->status.job);
        break;
    case PROTO_FETCH:
        assert_int_equal(a->fetch.job, b->fetch.job);
        assert_int_equal(a->fetch.what, b->fetch.what);
        break;
    case PROTO_SUBMITTED:
        assert_int_equal(a->submitted.job, b->submitted.job);
        break;
    case PROTO_STATUS_REPLY:
    case PROTO_JOBS_REPLY:
        assert_int_equal(a->jobs_reply.njobs, b->jobs_reply.njobs);
        for (size_t i = 0; i < a->jobs_reply.njobs; i++) {
            const proto_job_info_t *x = &a->jobs_reply.jobs[i], *y = &b->jobs_reply.jobs[i];
            assert_int_equal(x->id, y->id);
            assert_string_equal(x->name, y->name);
            assert_int_equal(x->state, y->state);
            assert_int_equal(x->samples_done, y->samples_done);
            assert_int_equal(x->samples_total, y->samples_total);
            assert_true(x->elapsed == y->elapsed);
            assert_opt_string_equal(x->error, y->error);
            assert_int_equal(x->nonfinite, y->nonfinite);
            assert_int_equal(x->spp, y->spp);
            assert_int_equal(x->has_rel_error, y->has_rel_error);
            assert_true(!x->has_rel_error || x->rel_error == y->rel_error);
            assert_int_equal(x->stop, y->stop);
            assert_opt_string_equal(x->owner, y->owner);
            assert_true(x->priority == y->priority);
            assert_int_equal(x->frames, y->frames);
            assert_int_equal(x->parent, y->parent);
            assert_int_equal(x->frame, y->frame);
            assert_int_equal(x->photons_done, y->photons_done);
            assert_int_equal(x->photons_total, y->photons_total);
        }
        break;
    case PROTO_WORKERS_REPLY:
        assert_int_equal(a->workers_reply.nworkers, b->workers_reply.nworkers);
        for (size_t i = 0; i < a->workers_reply.nworkers; i++) {
            const proto_worker_info_t *x = &a->workers_reply.workers[i];
            const proto_worker_info_t *y = &b->workers_reply.workers[i];
            assert_string_equal(x->name, y->name);
            assert_int_equal(x->id, y->id);
            assert_int_equal(x->threads, y->threads);
            assert_int_equal(x->state, y->state);
            assert_int_equal(x->tasks_done, y->tasks_done);
            assert_true(x->last_seen == y->last_seen);
            assert_int_equal(x->tasks_failed, y->tasks_failed);
            assert_int_equal(x->fail_streak, y->fail_streak);
            assert_int_equal(x->blocked_jobs, y->blocked_jobs);
            assert_true(x->samples_per_s == y->samples_per_s);
        }
        break;
    case PROTO_FILE:
        assert_string_equal(a->file.name, b->file.name);
        assert_int_equal(a->file.size, b->file.size);
        assert_memory_equal(a->file.data, b->file.data, a->file.size);
        break;
    case PROTO_ERROR:
        assert_string_equal(a->error.message, b->error.message);
        break;
    case PROTO_STORE_REQUEST:
        assert_string_equal(a->store_request.store, b->store_request.store);
        break;
    case PROTO_REFINE:
        assert_int_equal(a->refine.job, b->refine.job);
        assert_int_equal(a->refine.photons, b->refine.photons);
        break;
    case PROTO_PROGRESS:
        assert_string_equal(a->progress.message, b->progress.message);
        assert_true(a->progress.elapsed == b->progress.elapsed);
        break;
    case PROTO_ACT:
        assert_int_equal(a->act.act, b->act.act);
        assert_int_equal(a->act.job, b->act.job);
        assert_int_equal(a->act.task, b->act.task);
        assert_true(a->act.priority == b->act.priority);
        assert_true((a->act.worker == NULL) == (b->act.worker == NULL));
        break;
    case PROTO_LOGS:
        assert_int_equal(a->logs.job, b->logs.job);
        assert_int_equal(a->logs.has_task, b->logs.has_task);
        assert_int_equal(a->logs.task, b->logs.task);
        break;
    case PROTO_STORE:
        assert_string_equal(a->store.store, b->store.store);
        assert_int_equal(a->store.size, b->store.size);
        assert_memory_equal(a->store.data, b->store.data, a->store.size);
        break;
    default:
        break;
    }
}

/* ---------------------------------------------------------------- helpers */

static void encode_ok(const proto_msg_t *m, msgpack_sbuffer *sb)
{
    err_t err = {""};
    msgpack_sbuffer_init(sb);
    int rc = proto_encode(m, NULL, sb, &err);
    if (rc != 0)
        fail_msg("encoding %s: %s", proto_type_name(m->type), err.msg);
}

/* Decoding must return rc, with an error containing needle (when not NULL). */
static void expect_reject(const void *data, size_t len, int rc, const char *needle)
{
    proto_msg_t m;
    err_t err = {""};
    int got = proto_decode(data, len, NULL, &m, &err);
    if (got != rc)
        fail_msg("decode returned %d, expected %d (error: '%s')", got, rc, err.msg);
    if (needle && !strstr(err.msg, needle))
        fail_msg("error '%s' does not contain '%s'", err.msg, needle);
    if (rc != 0)
        assert_null(m.owned); /* a failed decode leaves nothing behind */
    proto_msg_free(&m);
}

/* Re-packs o, replacing the value at a dotted path ("tile.sums", "jobs.1.name"; numbers index
 * arrays) with repl, or dropping that key when repl is NULL. */
static void repack(msgpack_packer *pk, const msgpack_object *o, const char *path,
                   const msgpack_object *repl)
{
    if (!path) {
        assert_int_equal(msgpack_pack_object(pk, *o), 0);
        return;
    }
    const char *dot = strchr(path, '.');
    size_t n = dot ? (size_t)(dot - path) : strlen(path);
    const char *rest = dot ? dot + 1 : NULL;
    if (o->type == MSGPACK_OBJECT_ARRAY) {
        size_t idx = (size_t)strtoul(path, NULL, 10);
        assert_int_equal(msgpack_pack_array(pk, o->via.array.size), 0);
        for (uint32_t i = 0; i < o->via.array.size; i++)
            repack(pk, &o->via.array.ptr[i], i == idx ? rest : NULL, repl);
        return;
    }
    assert_int_equal(o->type, MSGPACK_OBJECT_MAP);
    int found = -1;
    for (uint32_t i = 0; i < o->via.map.size; i++) {
        const msgpack_object *k = &o->via.map.ptr[i].key;
        if (k->type == MSGPACK_OBJECT_STR && k->via.str.size == n &&
            memcmp(k->via.str.ptr, path, n) == 0)
            found = (int)i;
    }
    if (found < 0)
        fail_msg("no key '%.*s' to replace", (int)n, path);
    int drop = !rest && !repl;
    assert_int_equal(msgpack_pack_map(pk, o->via.map.size - (drop ? 1 : 0)), 0);
    for (uint32_t i = 0; i < o->via.map.size; i++) {
        if ((int)i == found && drop)
            continue;
        assert_int_equal(msgpack_pack_object(pk, o->via.map.ptr[i].key), 0);
        if ((int)i != found)
            assert_int_equal(msgpack_pack_object(pk, o->via.map.ptr[i].val), 0);
        else if (rest)
            repack(pk, &o->via.map.ptr[i].val, rest, repl);
        else
            assert_int_equal(msgpack_pack_object(pk, *repl), 0);
    }
}

/* The encoding of m with one field replaced (or dropped): out must be destroyed by the caller. */
static void mutate(const proto_msg_t *m, const char *path, const msgpack_object *repl,
                   msgpack_sbuffer *out)
{
    msgpack_sbuffer sb;
    encode_ok(m, &sb);
    msgpack_unpacked u;
    msgpack_unpacked_init(&u);
    size_t off = 0;
    assert_int_equal(msgpack_unpack_next(&u, sb.data, sb.size, &off), MSGPACK_UNPACK_SUCCESS);
    msgpack_sbuffer_init(out);
    msgpack_packer pk;
    msgpack_packer_init(&pk, out, msgpack_sbuffer_write);
    repack(&pk, &u.data, path, repl);
    msgpack_unpacked_destroy(&u);
    msgpack_sbuffer_destroy(&sb);
}

static void expect_mutation_rejected(proto_type_t t, const char *path, const msgpack_object *repl,
                                     int rc, const char *needle)
{
    proto_msg_t m = sample(t);
    msgpack_sbuffer sb;
    mutate(&m, path, repl, &sb);
    expect_reject(sb.data, sb.size, rc, needle);
    msgpack_sbuffer_destroy(&sb);
}

static msgpack_object obj_nil(void)
{
    return (msgpack_object){.type = MSGPACK_OBJECT_NIL};
}
static msgpack_object obj_uint(uint64_t v)
{
    return (msgpack_object){.type = MSGPACK_OBJECT_POSITIVE_INTEGER, .via.u64 = v};
}
static msgpack_object obj_str(const char *s)
{
    return (msgpack_object){.type = MSGPACK_OBJECT_STR,
                            .via.str = {.size = (uint32_t)strlen(s), .ptr = s}};
}
static msgpack_object obj_bin(const void *p, size_t n)
{
    return (msgpack_object){.type = MSGPACK_OBJECT_BIN, .via.bin = {.size = (uint32_t)n, .ptr = p}};
}

/* ---------------------------------------------------------------- tests */

static void test_round_trip_every_type(void **state)
{
    (void)state;
    for (int t = PROTO_NONE + 1; t < PROTO_TYPE_COUNT; t++) {
        proto_msg_t m = sample((proto_type_t)t);
        msgpack_sbuffer sb, again;
        encode_ok(&m, &sb);
        proto_msg_t d;
        err_t err = {""};
        int rc = proto_decode(sb.data, sb.size, NULL, &d, &err);
        if (rc != 0)
            fail_msg("decoding %s: %s", proto_type_name((proto_type_t)t), err.msg);
        assert_int_equal(d.version, PROTO_VERSION);
        assert_msg_equal(&m, &d);
        /* The encoding is canonical: the decoded message encodes to the same bytes. */
        encode_ok(&d, &again);
        assert_int_equal(again.size, sb.size);
        assert_memory_equal(again.data, sb.data, sb.size);
        proto_msg_free(&d);
        assert_int_equal(d.type, PROTO_NONE);
        assert_null(d.owned);
        proto_msg_free(&m); /* harmless on a message the caller built */
        msgpack_sbuffer_destroy(&sb);
        msgpack_sbuffer_destroy(&again);
    }
}

/* Decoded arrays must not point into the input (which the caller frees) and must be aligned. */
/* The photon pass's messages: a batch task, its result with a partial store, a camera tile
 * that names the merged store, and the store itself, which must hash to its name. */
static void round_trip(const proto_msg_t *m)
{
    msgpack_sbuffer sb;
    encode_ok(m, &sb);
    proto_msg_t d;
    err_t err = {""};
    if (proto_decode(sb.data, sb.size, NULL, &d, &err) != 0)
        fail_msg("decoding %s: %s", proto_type_name(m->type), err.msg);
    assert_msg_equal(m, &d);
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);
}

static void expect_encode_refused(const proto_msg_t *m, const char *needle)
{
    msgpack_sbuffer sb;
    msgpack_sbuffer_init(&sb);
    err_t err = {""};
    assert_int_equal(proto_encode(m, NULL, &sb, &err), -1);
    if (!strstr(err.msg, needle))
        fail_msg("expected '%s' in '%s'", needle, err.msg);
    msgpack_sbuffer_destroy(&sb);
}

static void test_photon_messages(void **state)
{
    (void)state;
    proto_msg_t t = sample(PROTO_TASK);
    t.task.kind = PROTO_KIND_PHOTON_BATCH;
    t.task.photons = (proto_photon_batch_t){1000000, 1250000};
    round_trip(&t);
    proto_msg_t c = sample(PROTO_TASK);
    memcpy(c.task.store, g_hash, sizeof g_hash);
    round_trip(&c);
    proto_msg_t r = sample(PROTO_RESULT);
    r.result.kind = PROTO_KIND_PHOTON_BATCH;
    r.result.photons = (proto_photon_result_t){.range = {0, 4096},
                                               .emitted = 4096 * 16,
                                               .data = g_png,
                                               .size = sizeof g_png,
                                               .nonfinite = 3};
    round_trip(&r);
    /* Limits: an empty range, and more than 64 lanes a photon. */
    t.task.photons = (proto_photon_batch_t){5, 5};
    expect_encode_refused(&t, "is not a photon range");
    r.result.photons.emitted = 4096 * 65;
    expect_encode_refused(&r, "photons.emitted");
    r.result.photons.emitted = 4095;
    expect_encode_refused(&r, "photons.emitted");
    /* A STORE whose data do not hash to its name would poison a worker's cache. */
    proto_msg_t st = sample(PROTO_STORE);
    st.store.store[0] = st.store.store[0] == 'a' ? 'b' : 'a';
    expect_encode_refused(&st, "but the data hash to");
    proto_msg_t rf = sample(PROTO_REFINE);
    rf.refine.photons = 0;
    expect_encode_refused(&rf, "expected 1 to 2^40");
}

/* Frame sequences: SUBMIT's frames, a TASK's main, a sequence's and its frames' job infos
 * travel; a frame not in the bundle, a repeated frame or number, and a main that is not a
 * bundle path are refused on both sides. */
static void test_frame_sequences(void **state)
{
    (void)state;
    proto_msg_t s = sample(PROTO_SUBMIT);
    s.submit.frames = g_frames;
    s.submit.nframes = 2;
    round_trip(&s);
    proto_msg_t t = sample(PROTO_TASK);
    t.task.main = "meshes/prism.ply";
    round_trip(&t);
    proto_msg_t r = {.type = PROTO_STATUS_REPLY, .status_reply = {.jobs = g_sequence, .njobs = 3}};
    round_trip(&r);
    proto_frame_t bad[2] = {{"scene.pbrt", 1}, {"missing.pbrt", 2}};
    s.submit.frames = bad;
    expect_encode_refused(&s, "entry 1 names 'missing.pbrt', which is not in the bundle");
    bad[1] = (proto_frame_t){"scene.pbrt", 2};
    expect_encode_refused(&s, "has 'scene.pbrt' twice");
    bad[1] = (proto_frame_t){"meshes/prism.ply", 1};
    expect_encode_refused(&s, "has the number 1 twice");
    t.task.main = "../scene.pbrt";
    expect_encode_refused(&t, "field 'main' is not a bundle path");
}

static void test_decoded_message_owns_its_data(void **state)
{
    (void)state;
    proto_msg_t m = sample(PROTO_RESULT);
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    char *copy = malloc(sb.size);
    memcpy(copy, sb.data, sb.size);
    proto_msg_t d;
    err_t err;
    assert_int_equal(proto_decode(copy, sb.size, NULL, &d, &err), 0);
    memset(copy, 0xA5, sb.size);
    free(copy);
    assert_int_equal((uintptr_t)d.result.tile.sums % _Alignof(double), 0);
    assert_int_equal((uintptr_t)d.result.tile.counts % _Alignof(uint64_t), 0);
    assert_msg_equal(&m, &d);
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);
}

static void count_release(void *arg)
{
    (*(int *)arg)++;
}

/* proto_decode_lent: a bundle's file data points into the input (not copied), the input is
 * released exactly once with the message, and not at all when the decode fails. */
static void test_lent_bundle_points_into_input(void **state)
{
    (void)state;
    proto_msg_t m = sample(PROTO_SUBMIT);
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    proto_msg_t d;
    err_t err;
    int released = 0;
    assert_int_equal(proto_decode_lent(sb.data, sb.size, NULL, &d, count_release, &released, &err),
                     0);
    assert_msg_equal(&m, &d);
    for (size_t i = 0; i < d.submit.bundle.nfiles; i++) {
        const uint8_t *p = d.submit.bundle.files[i].data;
        if (d.submit.bundle.files[i].size > 0)
            assert_true(p >= (const uint8_t *)sb.data && p < (const uint8_t *)sb.data + sb.size);
    }
    assert_int_equal(released, 0);
    proto_msg_free(&d);
    assert_int_equal(released, 1);
    proto_msg_free(&d); /* zeroed: a second free releases nothing */
    assert_int_equal(released, 1);
    /* A message with no byte field releases its input at once: it needs no freeing. */
    proto_msg_t hb = {.type = PROTO_HEARTBEAT};
    msgpack_sbuffer hsb;
    encode_ok(&hb, &hsb);
    assert_int_equal(
        proto_decode_lent(hsb.data, hsb.size, NULL, &d, count_release, &released, &err), 0);
    assert_int_equal(released, 2);
    proto_msg_free(&d);
    assert_int_equal(released, 2);
    msgpack_sbuffer_destroy(&hsb);
    assert_null(d.wire);
    /* A RESULT (its tile arrays are copies) keeps its input as its wire bytes, which the master
     * journals as received. */
    proto_msg_t res = sample(PROTO_RESULT);
    msgpack_sbuffer rsb;
    encode_ok(&res, &rsb);
    assert_int_equal(
        proto_decode_lent(rsb.data, rsb.size, NULL, &d, count_release, &released, &err), 0);
    assert_int_equal(released, 2);
    assert_ptr_equal(d.wire, rsb.data);
    assert_int_equal(d.wire_size, rsb.size);
    proto_msg_free(&d);
    assert_int_equal(released, 3);
    msgpack_sbuffer_destroy(&rsb);
    released = 1;
    /* A failed decode leaves the input with the caller. */
    assert_true(proto_decode_lent(sb.data, sb.size - 1, NULL, &d, count_release, &released, &err) <
                0);
    assert_int_equal(released, 1);
    msgpack_sbuffer_destroy(&sb);
}

static void test_status_all_and_optional_fields(void **state)
{
    (void)state;
    proto_msg_t m = {.type = PROTO_STATUS, .status = {.all = true}};
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    proto_msg_t d;
    err_t err;
    assert_int_equal(proto_decode(sb.data, sb.size, NULL, &d, &err), 0);
    assert_true(d.status.all);
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);
    /* Settings and job errors are optional; everything else is required. */
    expect_mutation_rejected(PROTO_SUBMIT, "set.integ", NULL, 0, NULL);
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.1.err", NULL, 0, NULL);
    /* So are the stopping rules and a job's accuracy figures (an older peer's messages). */
    expect_mutation_rejected(PROTO_SUBMIT, "set.tgt", NULL, 0, NULL);
    expect_mutation_rejected(PROTO_SUBMIT, "set.tlim", NULL, 0, NULL);
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.0.spp", NULL, 0, NULL);
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.0.rmse", NULL, 0, NULL);
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.3.stop", NULL, 0, NULL);
    /* Absent means none: an empty job map keeps spp 0, no estimate, no early stop. */
    proto_msg_t j = sample(PROTO_JOBS_REPLY);
    mutate(&j, "jobs.0.rmse", NULL, &sb);
    assert_int_equal(proto_decode(sb.data, sb.size, NULL, &d, &err), 0);
    assert_false(d.jobs_reply.jobs[0].has_rel_error);
    assert_int_equal(d.jobs_reply.jobs[0].spp, 4);
    assert_int_equal(d.jobs_reply.jobs[1].spp, 0);
    assert_int_equal(d.jobs_reply.jobs[1].stop, PROTO_STOP_NONE);
    assert_int_equal(d.jobs_reply.jobs[3].stop, PROTO_STOP_TARGET);
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);
}

/* The stopping rules and accuracy figures: ranges checked on both sides, values that the
 * encoder never writes (an explicit 0, a NaN) refused. */
static void test_accuracy_fields_strict(void **state)
{
    (void)state;
    msgpack_object f;
    f = (msgpack_object){.type = MSGPACK_OBJECT_FLOAT64, .via.f64 = 1.0};
    expect_mutation_rejected(PROTO_SUBMIT, "set.tgt", &f, PROTO_EMALFORMED,
                             "SUBMIT: field 'set.tgt' is 1, expected a relative error in (0, 1)");
    f.via.f64 = 0.0;
    expect_mutation_rejected(PROTO_SUBMIT, "set.tgt", &f, PROTO_EMALFORMED, "'set.tgt' is 0");
    f.via.f64 = -0.5;
    expect_mutation_rejected(PROTO_SUBMIT, "set.tgt", &f, PROTO_EMALFORMED, "'set.tgt' is -0.5");
    f.via.f64 = NAN;
    expect_mutation_rejected(PROTO_SUBMIT, "set.tgt", &f, PROTO_EMALFORMED, "'set.tgt' is nan");
    f.via.f64 = 0.0;
    expect_mutation_rejected(PROTO_SUBMIT, "set.tlim", &f, PROTO_EMALFORMED, "'set.tlim' is 0");
    f.via.f64 = INFINITY;
    expect_mutation_rejected(PROTO_SUBMIT, "set.tlim", &f, PROTO_EMALFORMED, "'set.tlim' is inf");
    f.via.f64 = 4e7; /* beyond a year */
    expect_mutation_rejected(PROTO_SUBMIT, "set.tlim", &f, PROTO_EMALFORMED, "'set.tlim' is 4e+07");
    msgpack_object u = obj_uint(1);
    expect_mutation_rejected(PROTO_SUBMIT, "set.tlim", &u, PROTO_EMALFORMED,
                             "'set.tlim' is an unsigned integer, expected a float");
    f.via.f64 = -0.25;
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.0.rmse", &f, PROTO_EMALFORMED,
                             "JOBS_REPLY: field 'jobs[0].rmse' is -0.25");
    f.via.f64 = NAN;
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.0.rmse", &f, PROTO_EMALFORMED,
                             "'jobs[0].rmse' is nan");
    u = obj_uint(0);
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.0.spp", &u, PROTO_EMALFORMED,
                             "'jobs[0].spp' is 0");
    u = obj_uint((uint64_t)INT_MAX + 1);
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.0.spp", &u, PROTO_EMALFORMED, "'jobs[0].spp'");
    msgpack_object st = obj_str("none");
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.3.stop", &st, PROTO_EMALFORMED,
                             "'jobs[3].stop' is 'none', expected one of: target, time");
    /* A photon pass never has more photons merged than it has. */
    u = obj_uint(30001);
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.0.pdone", &u, PROTO_EMALFORMED,
                             "30001 photons merged of a pass of 30000");
    /* The encoder refuses what the decoder would. */
    proto_job_info_t bad = g_jobs[0];
    bad.rel_error = NAN;
    proto_msg_t m = {.type = PROTO_JOBS_REPLY, .jobs_reply = {.jobs = &bad, .njobs = 1}};
    msgpack_sbuffer sb;
    msgpack_sbuffer_init(&sb);
    err_t err;
    assert_int_equal(proto_encode(&m, NULL, &sb, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "'jobs[0].rmse'"));
    proto_msg_t sub = sample(PROTO_SUBMIT);
    sub.submit.settings.target_error = 1.5;
    assert_int_equal(proto_encode(&sub, NULL, &sb, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "'set.tgt'"));
    msgpack_sbuffer_destroy(&sb);
}

static void test_version_refusal(void **state)
{
    (void)state;
    /* A peer of version 2 (tile results without XYZ sums) is refused by version 3, and so is
     * one of version 1. */
    assert_int_equal(PROTO_VERSION, 3);
    proto_msg_t m = sample(PROTO_HELLO);
    m.version = 2;
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    proto_msg_t d;
    err_t err;
    assert_int_equal(proto_decode(sb.data, sb.size, NULL, &d, &err), PROTO_EVERSION);
    assert_int_equal(d.version, 2);
    assert_int_equal(d.type, PROTO_NONE);
    assert_null(d.owned);
    assert_string_equal(err.msg, "HELLO: protocol version 2 not supported (speaks 3)");
    msgpack_sbuffer_destroy(&sb);
    /* Its RESULT too, whatever it holds. */
    m = sample(PROTO_RESULT);
    m.version = 2;
    encode_ok(&m, &sb);
    assert_int_equal(proto_decode(sb.data, sb.size, NULL, &d, &err), PROTO_EVERSION);
    msgpack_sbuffer_destroy(&sb);

    /* The answer, and a v2 peer's view of it: REFUSE decodes whatever its version. */
    err_t text;
    proto_msg_t refuse = proto_refuse_version(d.version, "master", &text);
    assert_string_equal(refuse.refuse.reason,
                        "protocol version 2 not supported by this master (speaks 3)");
    refuse.version = 2;
    encode_ok(&refuse, &sb);
    assert_int_equal(proto_decode(sb.data, sb.size, NULL, &d, &err), 0);
    assert_int_equal(d.type, PROTO_REFUSE);
    assert_int_equal(d.version, 2);
    assert_string_equal(d.refuse.reason,
                        "protocol version 2 not supported by this master (speaks 3)");
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);

    /* ERROR too; version 0 is as foreign as 1. */
    proto_msg_t e = {.type = PROTO_ERROR, .version = 7, .error = {.message = "bye"}};
    encode_ok(&e, &sb);
    assert_int_equal(proto_decode(sb.data, sb.size, NULL, &d, &err), 0);
    assert_int_equal(d.version, 7);
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);
    msgpack_object zero = obj_uint(0);
    expect_mutation_rejected(PROTO_TASK, "v", &zero, PROTO_EVERSION,
                             "protocol version 0 not supported");
}

static void test_truncated_at_every_byte(void **state)
{
    (void)state;
    proto_msg_t m = sample(PROTO_RESULT);
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    for (size_t len = 0; len < sb.size; len++) {
        /* A copy of exactly len bytes, so that ASan sees any read past the end. */
        char *p = malloc(len ? len : 1);
        memcpy(p, sb.data, len);
        expect_reject(p, len, PROTO_EMALFORMED, "malformed msgpack");
        free(p);
    }
    msgpack_sbuffer_destroy(&sb);
}

static void test_lying_container_headers(void **state)
{
    (void)state;
    /* array32 claiming 2^28 elements with nothing after it: msgpack-c alone would allocate
     * 2^28 * 24 bytes = 6 GiB before noticing. */
    const uint8_t arr[] = {0xdd, 0x10, 0x00, 0x00, 0x00};
    expect_reject(arr, sizeof arr, PROTO_EMALFORMED, "announces 268435456 elements");
    /* The same inside a valid-looking message with some bytes after it. */
    uint8_t msg[64] = {0x83, 0xa1, 'v',  0x01, 0xa1, 't',  0xa4, 'J',  'O',
                       'B',  'S',  0xa1, 'x',  0xdd, 0x7f, 0xff, 0xff, 0xff};
    expect_reject(msg, sizeof msg, PROTO_EMALFORMED, "array at byte 13 announces 2147483647");
    /* A map too large for any message, whose entries are all there (2 bytes each). */
    static uint8_t bigmap[3 + 257 * 2];
    bigmap[0] = 0xde;
    bigmap[1] = 0x01;
    bigmap[2] = 0x01; /* 257 entries */
    for (int i = 0; i < 257; i++) {
        bigmap[3 + 2 * i] = (uint8_t)(i & 0x7f);
        bigmap[4 + 2 * i] = 0xc0;
    }
    expect_reject(bigmap, sizeof bigmap, PROTO_EMALFORMED, "has 257 entries, at most 256");
    /* 2^22 + 1 nils, all present: each is a byte, but msgpack-c would spend 24 on it. */
    size_t n = PROTO_MAX_OBJECTS + 1;
    uint8_t *nils = malloc(5 + n);
    nils[0] = 0xdd;
    nils[1] = (uint8_t)(n >> 24);
    nils[2] = (uint8_t)(n >> 16);
    nils[3] = (uint8_t)(n >> 8);
    nils[4] = (uint8_t)n;
    memset(nils + 5, 0xc0, n);
    expect_reject(nils, 5 + n, PROTO_EMALFORMED, "more than 4194304 objects");
    free(nils);
    /* A str32 claiming 4 GiB. */
    const uint8_t str[] = {0xdb, 0xff, 0xff, 0xff, 0xff, 'a'};
    expect_reject(str, sizeof str, PROTO_EMALFORMED, "has 4294967295 bytes, only 1 remain");
}

static void test_deep_nesting(void **state)
{
    (void)state;
    enum { DEPTH = 1000 };
    uint8_t buf[DEPTH + 1];
    memset(buf, 0x91, DEPTH); /* fixarray of one element, nested */
    buf[DEPTH] = 0xc0;
    expect_reject(buf, sizeof buf, PROTO_EMALFORMED, "nested deeper than 16");
    /* 16 levels pass the walker (and then fail as a message, not as msgpack). */
    memset(buf, 0x91, 16);
    buf[16] = 0xc0;
    expect_reject(buf, 17, PROTO_EMALFORMED, "message is an array, expected a map");
    memset(buf, 0x91, 17);
    buf[17] = 0xc0;
    expect_reject(buf, 18, PROTO_EMALFORMED, "nested deeper than 16");
}

static void test_trailing_bytes_and_garbage(void **state)
{
    (void)state;
    proto_msg_t m = sample(PROTO_CANCEL);
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    char buf[256];
    memcpy(buf, sb.data, sb.size);
    buf[sb.size] = (char)0xc0;
    expect_reject(buf, sb.size + 1, PROTO_EMALFORMED, "1 trailing bytes");
    memcpy(buf + sb.size, sb.data, sb.size); /* two messages back to back */
    expect_reject(buf, 2 * sb.size, PROTO_EMALFORMED, "trailing bytes");
    msgpack_sbuffer_destroy(&sb);
    expect_reject(NULL, 0, PROTO_EMALFORMED, "truncated");
    const uint8_t ext[] = {0xd4, 0x01, 0x00};
    expect_reject(ext, sizeof ext, PROTO_EMALFORMED, "tag 0xd4");
    const uint8_t c1[] = {0xc1};
    expect_reject(c1, sizeof c1, PROTO_EMALFORMED, "tag 0xc1");
    const uint8_t notmap[] = {0x92, 0x01, 0x02};
    expect_reject(notmap, sizeof notmap, PROTO_EMALFORMED, "expected a map");
}

static void test_envelope_errors(void **state)
{
    (void)state;
    msgpack_object foo = obj_str("FOO"), none = obj_str("NONE"),
                   neg = {.type = MSGPACK_OBJECT_NEGATIVE_INTEGER, .via.i64 = -1};
    expect_mutation_rejected(PROTO_HELLO, "t", &foo, PROTO_EMALFORMED,
                             "message type 'FOO' is unknown");
    expect_mutation_rejected(PROTO_HELLO, "t", &none, PROTO_EMALFORMED, "unknown");
    expect_mutation_rejected(PROTO_HELLO, "v", &neg, PROTO_EMALFORMED,
                             "field 'v' is a negative integer");
    expect_mutation_rejected(PROTO_HELLO, "v", NULL, PROTO_EMALFORMED, "field 'v' is missing");
    expect_mutation_rejected(PROTO_HELLO, "t", NULL, PROTO_EMALFORMED, "field 't' is missing");
    /* A known key twice; an unknown key is ignored (forward compatibility). */
    const uint8_t V = PROTO_VERSION; /* a positive fixint */
    const uint8_t dup[] = {0x83, 0xa1, 'v', V, 0xa1, 't', 0xa3, 'J', 'O', 'B', 0xa1, 'v', V};
    expect_reject(dup, sizeof dup, PROTO_EMALFORMED, "has the key 'v' twice");
    const uint8_t extra[] = {0x83, 0xa1, 'v',  V,   0xa1, 't',  0xa4, 'J', 'O',
                             'B',  'S',  0xa2, 'z', 'z',  0x92, 0x80, 0x90};
    proto_msg_t d;
    err_t err;
    assert_int_equal(proto_decode(extra, sizeof extra, NULL, &d, &err), 0);
    assert_int_equal(d.type, PROTO_JOBS);
    proto_msg_free(&d);
    const uint8_t intkey[] = {0x83, 0xa1, 'v', V, 0xa1, 't', 0xa4, 'J', 'O', 'B', 'S', 0x01, 0x02};
    expect_reject(intkey, sizeof intkey, PROTO_EMALFORMED, "has a key that is an unsigned");
}

/* Every required field of every message: missing, or nil instead of its type, names the field. */
static void test_missing_and_wrong_type_fields(void **state)
{
    (void)state;
    static const struct {
        proto_type_t type;
        const char *path;  /* where to mutate */
        const char *field; /* how the error names it */
    } F[] = {
        {PROTO_HELLO, "name", "'name'"},
        {PROTO_HELLO, "threads", "'threads'"},
        {PROTO_HELLO, "sw", "'sw'"},
        {PROTO_WELCOME, "wid", "'wid'"},
        {PROTO_WELCOME, "hb", "'hb'"},
        {PROTO_TASK, "job", "'job'"},
        {PROTO_TASK, "task", "'task'"},
        {PROTO_TASK, "att", "'att'"},
        {PROTO_TASK, "scene", "'scene'"},
        {PROTO_TASK, "set", "'set'"},
        {PROTO_TASK, "set.spp", "'set.spp'"},
        {PROTO_TASK, "set.seed", "'set.seed'"},
        {PROTO_TASK, "set.xres", "'set.xres'"},
        {PROTO_TASK, "set.yres", "'set.yres'"},
        {PROTO_TASK, "kind", "'kind'"},
        {PROTO_TASK, "tile", "'tile'"},
        {PROTO_TASK, "tile.x0", "'tile.x0'"},
        {PROTO_TASK, "tile.se", "'tile.se'"},
        {PROTO_RESULT, "job", "'job'"},
        {PROTO_RESULT, "att", "'att'"},
        {PROTO_RESULT, "kind", "'kind'"},
        {PROTO_RESULT, "tile", "'tile'"},
        {PROTO_RESULT, "tile.w", "'tile.w'"},
        {PROTO_RESULT, "tile.nb", "'tile.nb'"},
        {PROTO_RESULT, "tile.sums", "'tile.sums'"},
        {PROTO_RESULT, "tile.counts", "'tile.counts'"},
        {PROTO_RESULT, "tile.lum", "'tile.lum'"},
        {PROTO_RESULT, "tile.lum2", "'tile.lum2'"},
        {PROTO_RESULT, "tile.nonfinite", "'tile.nonfinite'"},
        {PROTO_RESULT, "tile.sums_bits", "'tile.sums_bits'"},
        {PROTO_RESULT, "stats", "'stats'"},
        {PROTO_RESULT, "stats.secs", "'stats.secs'"},
        {PROTO_RESULT, "stats.rays", "'stats.rays'"},
        {PROTO_TASK_FAILED, "error", "'error'"},
        {PROTO_SCENE_REQUEST, "scene", "'scene'"},
        {PROTO_SCENE, "bundle", "'bundle'"},
        {PROTO_SCENE, "bundle.main", "'bundle.main'"},
        {PROTO_SCENE, "bundle.files", "'bundle.files'"},
        {PROTO_SCENE, "bundle.files.1.path", "'bundle.files[1].path'"},
        {PROTO_SCENE, "bundle.files.2.data", "'bundle.files[2].data'"},
        {PROTO_CANCEL, "job", "'job'"},
        {PROTO_REFUSE, "reason", "'reason'"},
        {PROTO_SUBMIT, "name", "'name'"},
        {PROTO_SUBMIT, "set", "'set'"},
        {PROTO_SUBMIT, "bundle", "'bundle'"},
        {PROTO_FETCH, "job", "'job'"},
        {PROTO_FETCH, "what", "'what'"},
        {PROTO_SUBMITTED, "job", "'job'"},
        {PROTO_STATUS_REPLY, "jobs", "'jobs'"},
        {PROTO_JOBS_REPLY, "jobs.2.state", "'jobs[2].state'"},
        {PROTO_JOBS_REPLY, "jobs.0.secs", "'jobs[0].secs'"},
        {PROTO_WORKERS_REPLY, "workers", "'workers'"},
        {PROTO_WORKERS_REPLY, "workers.1.seen", "'workers[1].seen'"},
        {PROTO_WORKERS_REPLY, "workers.0.threads", "'workers[0].threads'"},
        {PROTO_FILE, "name", "'name'"},
        {PROTO_FILE, "data", "'data'"},
        {PROTO_ERROR, "msg", "'msg'"},
    };
    msgpack_object nil = obj_nil();
    for (size_t i = 0; i < sizeof F / sizeof F[0]; i++) {
        char needle[96];
        proto_msg_t m = sample(F[i].type);
        msgpack_sbuffer sb;
        /* nil in place of the value */
        snprintf(needle, sizeof needle, "%s: field %s is nil", proto_type_name(F[i].type),
                 F[i].field);
        mutate(&m, F[i].path, &nil, &sb);
        expect_reject(sb.data, sb.size, PROTO_EMALFORMED, needle);
        msgpack_sbuffer_destroy(&sb);
        /* removed; list entries lose their required-field count first, which the list check
         * reports before allocating (so the entry, not the field, is named) */
        if (strstr(F[i].field, "["))
            continue;
        snprintf(needle, sizeof needle, "%s: field %s is missing", proto_type_name(F[i].type),
                 F[i].field);
        mutate(&m, F[i].path, NULL, &sb);
        expect_reject(sb.data, sb.size, PROTO_EMALFORMED, needle);
        msgpack_sbuffer_destroy(&sb);
    }
}

static void test_values_out_of_range(void **state)
{
    (void)state;
    msgpack_object big = obj_uint(5000), zero = obj_uint(0), huge = obj_uint(UINT64_MAX),
                   neg2 = {.type = MSGPACK_OBJECT_NEGATIVE_INTEGER, .via.i64 = -2},
                   dbl = {.type = MSGPACK_OBJECT_FLOAT64, .via.f64 = 1.5}, tif = obj_str("tiff"),
                   photons = obj_str("photons"), none = obj_str("none");
    expect_mutation_rejected(PROTO_RESULT, "tile.w", &big, PROTO_EMALFORMED,
                             "RESULT: field 'tile.w' is 5000, expected 1..4096");
    expect_mutation_rejected(PROTO_TASK, "tile.h", &zero, PROTO_EMALFORMED,
                             "TASK: field 'tile.h' is 0, expected 1..4096");
    expect_mutation_rejected(PROTO_RESULT, "tile.nb", &big, PROTO_EMALFORMED,
                             "RESULT: field 'tile.nb' is 5000, expected 1..4096");
    expect_mutation_rejected(PROTO_RESULT, "tile.x0", &huge, PROTO_EMALFORMED,
                             "field 'tile.x0' is 18446744073709551615, at most 2147483647");
    expect_mutation_rejected(PROTO_TASK, "tile.sb", &big, PROTO_EMALFORMED,
                             "TASK: field 'tile.se' is 164, expected more than tile.sb (5000)");
    expect_mutation_rejected(PROTO_TASK, "set.seed", &neg2, PROTO_EMALFORMED,
                             "TASK: field 'set.seed' is -2, expected -1..");
    expect_mutation_rejected(PROTO_TASK, "set.spp", &dbl, PROTO_EMALFORMED,
                             "field 'set.spp' is a float, expected an unsigned integer");
    expect_mutation_rejected(PROTO_HELLO, "threads", &zero, PROTO_EMALFORMED,
                             "HELLO: field 'threads' is 0, expected 1..4096");
    expect_mutation_rejected(PROTO_WELCOME, "hb", &zero, PROTO_EMALFORMED, "'hb' is 0");
    expect_mutation_rejected(PROTO_FETCH, "what", &tif, PROTO_EMALFORMED,
                             "FETCH: field 'what' is 'tiff', expected one of: exr, png");
    expect_mutation_rejected(PROTO_TASK, "kind", &photons, PROTO_EMALFORMED,
                             "TASK: field 'kind' is 'photons', expected one of: camera_tile");
    expect_mutation_rejected(PROTO_RESULT, "kind", &none, PROTO_EMALFORMED, "'kind' is 'none'");
    expect_mutation_rejected(PROTO_TASK, "scene", &tif, PROTO_EMALFORMED,
                             "TASK: field 'scene' has 4 bytes, expected 64 hex digits");
    char upper[PROTO_HASH_HEX + 1];
    memset(upper, 'A', PROTO_HASH_HEX);
    upper[PROTO_HASH_HEX] = 0;
    msgpack_object up = obj_str(upper);
    expect_mutation_rejected(PROTO_SCENE_REQUEST, "scene", &up, PROTO_EMALFORMED,
                             "is not 64 lower-case hex digits");
    /* Control characters in a name; NUL inside any string. */
    msgpack_object esc = obj_str("node\x1b[2J"),
                   nul = {.type = MSGPACK_OBJECT_STR, .via.str = {.size = 3, .ptr = "a\0b"}};
    expect_mutation_rejected(PROTO_HELLO, "name", &esc, PROTO_EMALFORMED,
                             "HELLO: field 'name' has a control character 0x1b");
    expect_mutation_rejected(PROTO_ERROR, "msg", &nul, PROTO_EMALFORMED,
                             "ERROR: field 'msg' contains a NUL byte");
    static char longs[PROTO_MAX_STRING + 2];
    memset(longs, 'x', PROTO_MAX_STRING + 1);
    msgpack_object lng = obj_str(longs);
    expect_mutation_rejected(PROTO_TASK_FAILED, "error", &lng, PROTO_EMALFORMED,
                             "TASK_FAILED: field 'error' has 4097 bytes, at most 4096 allowed");
    msgpack_object empty = obj_str("");
    expect_mutation_rejected(PROTO_SUBMIT, "name", &empty, PROTO_EMALFORMED,
                             "SUBMIT: field 'name' is empty");
}

static void test_bins_of_wrong_length_and_nonfinite(void **state)
{
    (void)state;
    /* sums of a 5x3 tile with 4 buckets: 60 doubles = 480 bytes. */
    static uint8_t bytes[488];
    msgpack_object shortb = obj_bin(bytes, 472), longb = obj_bin(bytes, 488),
                   counts = obj_bin(bytes, 128);
    expect_mutation_rejected(PROTO_RESULT, "tile.sums", &shortb, PROTO_EMALFORMED,
                             "RESULT: field 'tile.sums' has 472 bytes, expected 480");
    expect_mutation_rejected(PROTO_RESULT, "tile.sums", &longb, PROTO_EMALFORMED,
                             "RESULT: field 'tile.sums' has 488 bytes, expected 480");
    expect_mutation_rejected(PROTO_RESULT, "tile.counts", &counts, PROTO_EMALFORMED,
                             "RESULT: field 'tile.counts' has 128 bytes, expected 120");
    msgpack_object str = obj_str("not a bin");
    expect_mutation_rejected(PROTO_RESULT, "tile.lum", &str, PROTO_EMALFORMED,
                             "RESULT: field 'tile.lum' is a string, expected a bin");
    /* A growing tile must not outrun its bins: w 5 -> 6 with the same bins. */
    msgpack_object six = obj_uint(6);
    expect_mutation_rejected(PROTO_RESULT, "tile.w", &six, PROTO_EMALFORMED,
                             "field 'tile.sums' has 480 bytes, expected 576");

    /* NaN and Inf never travel: the encoder refuses them, and so does the decoder when a peer
     * sends them anyway (little-endian bytes patched in). */
    double saved = g_sums[7];
    g_sums[7] = NAN;
    proto_msg_t m = sample(PROTO_RESULT);
    msgpack_sbuffer sb;
    msgpack_sbuffer_init(&sb);
    err_t err;
    assert_int_equal(proto_encode(&m, NULL, &sb, &err), -1);
    assert_string_equal(err.msg, "RESULT: field 'tile.sums' element 7 is nan: results carry finite "
                                 "numbers only");
    assert_int_equal(sb.size, 0);
    msgpack_sbuffer_destroy(&sb);
    g_sums[7] = saved;
    static const double specials[] = {NAN, -NAN, INFINITY, -INFINITY};
    const char *fields[] = {"tile.sums", "tile.lum", "tile.lum2", "tile.xyz"};
    for (size_t f = 0; f < 4; f++)
        for (size_t s = 0; s < 4; s++) {
            size_t n = f == 0 ? RPIX * RNB : f == 3 ? RPIX * PROTO_TILE_XYZ : RPIX;
            double *vals = calloc(n, sizeof *vals);
            vals[n - 1] = specials[s];
            uint8_t *le = malloc(n * 8);
            for (size_t i = 0; i < n; i++) {
                uint64_t u;
                memcpy(&u, &vals[i], 8);
                for (int b = 0; b < 8; b++)
                    le[8 * i + (size_t)b] = (uint8_t)(u >> (8 * b));
            }
            msgpack_object bin = obj_bin(le, n * 8);
            char needle[80];
            snprintf(needle, sizeof needle, "field '%s' element %zu is", fields[f], n - 1);
            expect_mutation_rejected(PROTO_RESULT, fields[f], &bin, PROTO_EMALFORMED, needle);
            free(le);
            free(vals);
        }
    msgpack_object inf = {.type = MSGPACK_OBJECT_FLOAT64, .via.f64 = INFINITY};
    expect_mutation_rejected(PROTO_RESULT, "stats.secs", &inf, PROTO_EMALFORMED,
                             "RESULT: field 'stats.secs' is inf, expected a finite number");
    msgpack_object negsec = {.type = MSGPACK_OBJECT_FLOAT64, .via.f64 = -1.0};
    expect_mutation_rejected(PROTO_JOBS_REPLY, "jobs.1.secs", &negsec, PROTO_EMALFORMED,
                             "JOBS_REPLY: field 'jobs[1].secs' is -1");
}

/* A RESULT whose sums are all float values (tilebuf.h): zero of both signs, float's extremes,
 * and values rounded to float as tilebuf_round_sums leaves them. */
static double g_fsums[RPIX * RNB];

static proto_msg_t float_result(void)
{
    for (int i = 0; i < RPIX * RNB; i++)
        g_fsums[i] = (double)(float)((i - 30) * 0.1 + 1.0 / 3.0);
    g_fsums[0] = -0.0;
    g_fsums[1] = FLT_MIN;
    g_fsums[2] = FLT_MAX;
    g_fsums[3] = -FLT_MAX;
    g_fsums[4] = 0.0;
    proto_msg_t m = sample(PROTO_RESULT);
    m.result.tile.sums = g_fsums;
    return m;
}

/* Float32 sums as little-endian bytes, for patching a message. */
static uint8_t *float_bytes(const float *v, size_t n)
{
    uint8_t *le = malloc(n * 4);
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &v[i], 4);
        for (int b = 0; b < 4; b++)
            le[4 * i + (size_t)b] = (uint8_t)(u >> (8 * b));
    }
    return le;
}

static void test_float32_sums(void **state)
{
    (void)state;
    /* Both widths round-trip bit for bit: float values go as 32 bits when the sender lets the
     * encoder pick (sums_bits 0) or asks for 32, as 64 when asked; other sums as 64. */
    proto_msg_t m = float_result();
    msgpack_sbuffer narrow, wide;
    encode_ok(&m, &narrow);
    proto_msg_t d;
    err_t err = {""};
    assert_int_equal(proto_decode(narrow.data, narrow.size, NULL, &d, &err), 0);
    assert_int_equal(d.result.tile.sums_bits, 32);
    assert_msg_equal(&m, &d);
    assert_memory_equal(d.result.tile.sums, g_fsums, sizeof g_fsums); /* -0.0 kept too */
    assert_int_equal((uintptr_t)d.result.tile.sums % _Alignof(double), 0);
    /* Canonical: the decoded message (sums_bits 32) encodes to the same bytes. */
    msgpack_sbuffer again;
    encode_ok(&d, &again);
    assert_int_equal(again.size, narrow.size);
    assert_memory_equal(again.data, narrow.data, narrow.size);
    msgpack_sbuffer_destroy(&again);
    proto_msg_free(&d);
    m.result.tile.sums_bits = 64;
    encode_ok(&m, &wide);
    assert_int_equal(proto_decode(wide.data, wide.size, NULL, &d, &err), 0);
    assert_int_equal(d.result.tile.sums_bits, 64);
    assert_memory_equal(d.result.tile.sums, g_fsums, sizeof g_fsums);
    proto_msg_free(&d);
    /* 60 sums: 240 bytes (bin 8 header, 2 bytes) instead of 480 (bin 16 header, 3 bytes); the
     * 45 XYZ sums travel at the same width: 180 bytes (bin 8) instead of 360 (bin 16). */
    assert_int_equal(wide.size - narrow.size, 240 + 1 + 180 + 1);
    assert_int_equal(proto_decode(wide.data, wide.size, NULL, &d, &err), 0);
    assert_memory_equal(d.result.tile.xyz, g_xyz, sizeof g_xyz);
    proto_msg_free(&d);
    /* One XYZ sum that is not a float value: both arrays go as 64 bits when the encoder picks,
     * and asking for 32 is refused naming the XYZ field. */
    {
        proto_msg_t mx = float_result();
        double saved_xyz = g_xyz[5];
        g_xyz[5] = 1.0 / 3.0;
        msgpack_sbuffer sx;
        encode_ok(&mx, &sx);
        assert_int_equal(proto_decode(sx.data, sx.size, NULL, &d, &err), 0);
        assert_int_equal(d.result.tile.sums_bits, 64);
        assert_memory_equal(d.result.tile.sums, g_fsums, sizeof g_fsums);
        assert_memory_equal(d.result.tile.xyz, g_xyz, sizeof g_xyz);
        proto_msg_free(&d);
        msgpack_sbuffer_destroy(&sx);
        mx.result.tile.sums_bits = 32;
        expect_encode_refused(&mx, "RESULT: field 'tile.xyz' element 5 is");
        g_xyz[5] = saved_xyz;
    }
    m.result.tile.sums_bits = 32;
    round_trip(&m);

    /* The sample's sums (1/3, DBL_MAX, a double subnormal) are not float values: 64 bits. */
    proto_msg_t m64 = sample(PROTO_RESULT);
    msgpack_sbuffer sb;
    encode_ok(&m64, &sb);
    assert_int_equal(proto_decode(sb.data, sb.size, NULL, &d, &err), 0);
    assert_int_equal(d.result.tile.sums_bits, 64);
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);
    m64.result.tile.sums_bits = 32;
    expect_encode_refused(&m64, "RESULT: field 'tile.sums' element 1 is");
    expect_encode_refused(&m64, "not a normal float32 value (sums_bits is 32)");
    m64.result.tile.sums_bits = 16;
    expect_encode_refused(&m64, "RESULT: field 'tile.sums_bits' is 16, expected 32 or 64");
    m64.result.tile.sums_bits = 0;

    /* The decoder: a length that is not the declared width's, an unknown width. */
    msgpack_object w64 = obj_uint(64), w32 = obj_uint(32), w16 = obj_uint(16),
                   wf = {.type = MSGPACK_OBJECT_FLOAT64, .via.f64 = 32.0};
    m.result.tile.sums_bits = 0;
    mutate(&m, "tile.sums_bits", &w64, &sb);
    expect_reject(sb.data, sb.size, PROTO_EMALFORMED,
                  "RESULT: field 'tile.sums' has 240 bytes, expected 480");
    msgpack_sbuffer_destroy(&sb);
    mutate(&m64, "tile.sums_bits", &w32, &sb);
    expect_reject(sb.data, sb.size, PROTO_EMALFORMED,
                  "RESULT: field 'tile.sums' has 480 bytes, expected 240");
    msgpack_sbuffer_destroy(&sb);
    mutate(&m, "tile.sums_bits", &w16, &sb);
    expect_reject(sb.data, sb.size, PROTO_EMALFORMED,
                  "RESULT: field 'tile.sums_bits' is 16, expected 32 or 64");
    msgpack_sbuffer_destroy(&sb);
    mutate(&m, "tile.sums_bits", &wf, &sb);
    expect_reject(sb.data, sb.size, PROTO_EMALFORMED,
                  "RESULT: field 'tile.sums_bits' is a float, expected an unsigned integer");
    msgpack_sbuffer_destroy(&sb);

    /* NaN, Inf and subnormal float32s: refused (a sender's rounding rule never sends them). */
    float vals[RPIX * RNB];
    for (int i = 0; i < RPIX * RNB; i++)
        vals[i] = (float)g_fsums[i];
    static const struct {
        float v;
        const char *needle;
    } bad[] = {
        {NAN, "RESULT: field 'tile.sums' element 59 is nan: results carry finite numbers only"},
        {INFINITY, "RESULT: field 'tile.sums' element 59 is inf"},
        {-INFINITY, "RESULT: field 'tile.sums' element 59 is -inf"},
        {0x1p-149f, "element 59 is 1.4012984643248171e-45, not a normal float32 value"},
        {-0x1p-127f, "element 59 is -5.8774717541114375e-39, not a normal float32 value"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        vals[RPIX * RNB - 1] = bad[i].v;
        uint8_t *le = float_bytes(vals, RPIX * RNB);
        msgpack_object bin = obj_bin(le, sizeof vals);
        mutate(&m, "tile.sums", &bin, &sb);
        expect_reject(sb.data, sb.size, PROTO_EMALFORMED, bad[i].needle);
        msgpack_sbuffer_destroy(&sb);
        free(le);
    }
    /* The same bytes with a normal float there decode. */
    vals[RPIX * RNB - 1] = FLT_MIN;
    uint8_t *le = float_bytes(vals, RPIX * RNB);
    msgpack_object bin = obj_bin(le, sizeof vals);
    mutate(&m, "tile.sums", &bin, &sb);
    expect_reject(sb.data, sb.size, 0, NULL);
    msgpack_sbuffer_destroy(&sb);
    free(le);
    msgpack_sbuffer_destroy(&narrow);
    msgpack_sbuffer_destroy(&wide);
}

static void test_bad_bundle_paths(void **state)
{
    (void)state;
    static char deep[2 * 300];
    for (int i = 0; i < 300; i++) {
        deep[2 * i] = 'a';
        deep[2 * i + 1] = '/';
    }
    deep[2 * 300 - 1] = 0; /* "a/a/.../a": 300 components */
    static char longcomp[PROTO_MAX_PATH_COMPONENT + 2];
    memset(longcomp, 'c', PROTO_MAX_PATH_COMPONENT + 1);
    static const struct {
        const char *path, *why;
    } bad[] = {
        {"../x", "'..' component"},
        {"/etc/passwd", "is absolute"},
        {"a//b", "empty component"},
        {"a/./b", "'.' component"},
        {"", "is empty"},
        {"a/", "empty component"},
        {"a/..", "'..' component"},
        {".", "'.' component"},
        {"a\\..\\b", "forbidden byte 0x5c"},
        {"a\nb", "forbidden byte 0x0a"},
        {deep, "more than 32 components"},
        {longcomp, "component of 201 bytes"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err_t err = {""};
        assert_int_equal(proto_bundle_path_check(bad[i].path, &err), -1);
        if (!strstr(err.msg, bad[i].why))
            fail_msg("path %zu: '%s' lacks '%s'", i, err.msg, bad[i].why);
        /* The same path arriving in a SUBMIT. */
        msgpack_object p = obj_str(bad[i].path);
        expect_mutation_rejected(PROTO_SUBMIT, "bundle.files.1.path", &p, PROTO_EMALFORMED,
                                 bad[i].why);
    }
    static const char *const good[] = {"scene.pbrt", "a/b/c.ply", "..a",
                                       "a..",        ".hidden/x", "with space/ü.png"};
    for (size_t i = 0; i < sizeof good / sizeof good[0]; i++)
        assert_int_equal(proto_bundle_path_check(good[i], NULL), 0);
    /* main not among the files; a path twice; a file that is also a folder. */
    msgpack_object other = obj_str("other.pbrt"), dup = obj_str("scene.pbrt"),
                   asdir = obj_str("scene.pbrt/x");
    expect_mutation_rejected(PROTO_SUBMIT, "bundle.main", &other, PROTO_EMALFORMED,
                             "SUBMIT: field 'bundle': bundle main file 'other.pbrt' is not among");
    expect_mutation_rejected(PROTO_SUBMIT, "bundle.files.1.path", &dup, PROTO_EMALFORMED,
                             "has the path 'scene.pbrt' twice");
    expect_mutation_rejected(PROTO_SUBMIT, "bundle.files.2.path", &asdir, PROTO_EMALFORMED,
                             "uses 'scene.pbrt' both as a file and as a folder");
}

static void test_bundle_limits_are_the_callers(void **state)
{
    (void)state;
    proto_msg_t m = sample(PROTO_SUBMIT);
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    proto_limits_t lim = proto_limits_default();
    lim.max_bundle_files = 2;
    proto_msg_t d;
    err_t err;
    assert_int_equal(proto_decode(sb.data, sb.size, &lim, &d, &err), PROTO_EMALFORMED);
    assert_string_equal(err.msg, "SUBMIT: field 'bundle.files' has 3 entries, at most 2 allowed");
    lim = proto_limits_default();
    lim.max_bundle_bytes = 40; /* the scene file alone has more */
    assert_int_equal(proto_decode(sb.data, sb.size, &lim, &d, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "exceed 40 bytes"));
    lim = proto_limits_default();
    lim.max_message_bytes = sb.size - 1;
    assert_int_equal(proto_decode(sb.data, sb.size, &lim, &d, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "at most"));
    /* The encoder applies the same limits. */
    msgpack_sbuffer out;
    msgpack_sbuffer_init(&out);
    assert_int_equal(proto_encode(&m, &lim, &out, &err), -1);
    assert_non_null(strstr(err.msg, "encoded message has"));
    assert_int_equal(out.size, 0);
    msgpack_sbuffer_destroy(&out);
    msgpack_sbuffer_destroy(&sb);
    /* A SCENE whose hash does not match its bundle would poison workers' caches. */
    char wrong[PROTO_HASH_HEX + 1];
    memset(wrong, '0', PROTO_HASH_HEX);
    wrong[PROTO_HASH_HEX] = 0;
    msgpack_object w = obj_str(wrong);
    expect_mutation_rejected(PROTO_SCENE, "scene", &w, PROTO_EMALFORMED,
                             "SCENE: field 'scene' is 000000000000..., but the bundle hashes to");
}

static void test_list_bounds(void **state)
{
    (void)state;
    /* 100001 job entries, each the smallest map a job could be: refused before any entry is
     * read. */
    msgpack_sbuffer sb;
    msgpack_sbuffer_init(&sb);
    msgpack_packer pk;
    msgpack_packer_init(&pk, &sb, msgpack_sbuffer_write);
    assert_int_equal(msgpack_pack_map(&pk, 3), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "v", 1), 0);
    assert_int_equal(msgpack_pack_uint8(&pk, PROTO_VERSION), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "t", 1), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "JOBS_REPLY", 10), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "jobs", 4), 0);
    assert_int_equal(msgpack_pack_array(&pk, PROTO_MAX_LIST + 1), 0);
    for (int i = 0; i <= PROTO_MAX_LIST; i++)
        assert_int_equal(msgpack_pack_map(&pk, 0), 0);
    expect_reject(sb.data, sb.size, PROTO_EMALFORMED,
                  "JOBS_REPLY: field 'jobs' has 100001 entries, at most 100000 allowed");
    /* Within the count, an entry that cannot hold the required fields is refused before the
     * list is allocated. */
    msgpack_sbuffer_clear(&sb);
    assert_int_equal(msgpack_pack_map(&pk, 3), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "v", 1), 0);
    assert_int_equal(msgpack_pack_uint8(&pk, PROTO_VERSION), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "t", 1), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "WORKERS_REPLY", 13), 0);
    assert_int_equal(msgpack_pack_str_with_body(&pk, "workers", 7), 0);
    assert_int_equal(msgpack_pack_array(&pk, 50000), 0);
    for (int i = 0; i < 50000; i++)
        assert_int_equal(msgpack_pack_nil(&pk), 0);
    expect_reject(sb.data, sb.size, PROTO_EMALFORMED, "entry 0 is nil, expected a map");
    msgpack_sbuffer_destroy(&sb);
}

/* ---------------------------------------------------------------- fuzz */

static uint64_t xorshift(uint64_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

/* Random mutations of valid encodings of every type: decode must return 0 or an error, never
 * crash, leak or read out of bounds (the sanitizer build checks); and whatever it accepts must
 * encode again, since encode and decode enforce the same rules. */
static void test_fuzz_mutations(void **state)
{
    (void)state;
    enum { ROUNDS = 20000 };
    static const uint8_t interesting[] = {0x00, 0x7f, 0x80, 0x8f, 0x90, 0x9f, 0xc0,
                                          0xc1, 0xc4, 0xc6, 0xcb, 0xcf, 0xd3, 0xdb,
                                          0xdd, 0xdf, 0xff, 0x01, 0xa0, 0xbf};
    msgpack_sbuffer base[PROTO_TYPE_COUNT];
    for (int t = 1; t < PROTO_TYPE_COUNT; t++) {
        proto_msg_t m = sample((proto_type_t)t);
        encode_ok(&m, &base[t]);
    }
    uint64_t seed = 0x9E3779B97F4A7C15ULL;
    int accepted = 0;
    for (int round = 0; round < ROUNDS; round++) {
        const msgpack_sbuffer *b = &base[1 + xorshift(&seed) % (PROTO_TYPE_COUNT - 1)];
        size_t len = b->size;
        uint8_t *p = malloc(len + 16);
        memcpy(p, b->data, len);
        int nmut = 1 + (int)(xorshift(&seed) % 4);
        for (int k = 0; k < nmut; k++) {
            size_t at = (size_t)(xorshift(&seed) % len);
            switch (xorshift(&seed) % 6) {
            case 0:
                p[at] ^= (uint8_t)(1u << (xorshift(&seed) % 8));
                break;
            case 1:
                p[at] = interesting[xorshift(&seed) % sizeof interesting];
                break;
            case 2:
                p[at] = (uint8_t)xorshift(&seed);
                break;
            case 3:
                len = at;
                break; /* truncate */
            case 4:    /* insert a byte */
                if (len < b->size + 16) {
                    memmove(p + at + 1, p + at, len - at);
                    p[at] = interesting[xorshift(&seed) % sizeof interesting];
                    len++;
                }
                break;
            case 5: /* set a 32-bit length to something large */
                if (at + 4 <= len)
                    memset(p + at, 0x7f, 4);
                break;
            }
            if (len == 0)
                break;
        }
        /* An exact-size copy so that any read past the end is caught. */
        uint8_t *q = malloc(len ? len : 1);
        memcpy(q, p, len);
        free(p);
        proto_msg_t d;
        err_t err;
        int rc = proto_decode(q, len, NULL, &d, &err);
        assert_true(rc == 0 || rc == PROTO_EMALFORMED || rc == PROTO_EVERSION);
        if (rc == 0) {
            accepted++;
            msgpack_sbuffer re;
            msgpack_sbuffer_init(&re);
            if (proto_encode(&d, NULL, &re, &err) != 0)
                fail_msg("round %d: decoded %s does not encode: %s", round, proto_type_name(d.type),
                         err.msg);
            msgpack_sbuffer_destroy(&re);
        } else {
            assert_true(strlen(err.msg) > 0);
        }
        proto_msg_free(&d);
        free(q);
    }
    for (int t = 1; t < PROTO_TYPE_COUNT; t++)
        msgpack_sbuffer_destroy(&base[t]);
    print_message("fuzz: %d of %d mutations decoded as valid messages\n", accepted, ROUNDS);
}

/* The width the encoder picks for v alone (sums_bits 0), after checking that v comes back with
 * its bits. */
static int picked_width(double v)
{
    proto_msg_t m = sample(PROTO_RESULT);
    uint64_t count = 1;
    double zero = 0;
    m.result.tile.rect = (proto_tile_t){0, 0, 1, 1, 0, 1};
    m.result.tile.nbuckets = 1;
    m.result.tile.sums = &v;
    static const double zero_xyz[PROTO_TILE_XYZ] = {0};
    m.result.tile.xyz = zero_xyz;
    m.result.tile.counts = &count;
    m.result.tile.lum = m.result.tile.lum_sq = &zero;
    msgpack_sbuffer sb;
    encode_ok(&m, &sb);
    proto_msg_t d;
    err_t err = {""};
    if (proto_decode(sb.data, sb.size, NULL, &d, &err) != 0)
        fail_msg("decoding a sum of %a: %s", v, err.msg);
    assert_memory_equal(d.result.tile.sums, &v, sizeof v);
    int bits = d.result.tile.sums_bits;
    proto_msg_free(&d);
    msgpack_sbuffer_destroy(&sb);
    return bits;
}

/* proto's own float32 test decides the width as film's rule reads its rounded values
 * (tilebuf_is_float_value): zero of both signs and normal floats go as 32 bits, everything else
 * as 64, in the default floating-point mode and in the render threads' flush-to-zero and
 * denormals-are-zero mode. */
static void test_float32_width_matches_tilebuf(void **state)
{
    (void)state;
    static const double edges[] = {0.0,
                                   -0.0,
                                   1.0,
                                   -1.0,
                                   1.0 / 3.0,
                                   (double)(1.0f / 3.0f),
                                   FLT_MIN,
                                   -FLT_MIN,
                                   FLT_MAX,
                                   -FLT_MAX,
                                   0x1p-126 - 0x1p-149,
                                   0x1p-149,
                                   -0x1p-149,
                                   0x1p-127,
                                   (double)FLT_MIN * (1 - 0x1p-53),
                                   0x1p128,
                                   -0x1p128,
                                   (double)FLT_MAX + 0x1p103,
                                   1.0 + 0x1p-23,
                                   1.0 + 0x1p-24,
                                   1.0 + 0x1p-52,
                                   DBL_MIN,
                                   DBL_MIN / 4,
                                   -DBL_MIN / 4,
                                   DBL_MAX,
                                   0x1p-1074,
                                   65504.0,
                                   16777217.0,
                                   16777216.0};
    for (int mode = 0; mode < 2; mode++) {
#if defined(__SSE__)
        unsigned int csr = _mm_getcsr();
        if (mode == 1) {
            _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
            _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
        }
#else
        if (mode == 1)
            break;
#endif
        for (size_t i = 0; i < sizeof edges / sizeof edges[0]; i++)
            if (picked_width(edges[i]) != (tilebuf_is_float_value(edges[i]) ? 32 : 64))
                fail_msg("mode %d: %a goes as %d bits", mode, edges[i], picked_width(edges[i]));
        /* Random bit patterns, and random doubles near float's exponent range with a mantissa
         * that float may or may not hold. */
        uint64_t seed = 0x2545F4914F6CDD1DULL;
        for (int i = 0; i < 20000; i++) {
            uint64_t bits = xorshift(&seed);
            if (i % 2)
                bits = (bits & 0x800FFFFFE0000000ULL) | (uint64_t)(1023 - 130 + i % 262) << 52 |
                       (i % 4 == 1 ? 0 : bits & 0x1FFFFFFF);
            double v;
            memcpy(&v, &bits, sizeof v);
            if (!isfinite(v))
                continue; /* refused by the encoder whatever its width */
            if (picked_width(v) != (tilebuf_is_float_value(v) ? 32 : 64))
                fail_msg("mode %d: %a goes as %d bits", mode, v, picked_width(v));
        }
#if defined(__SSE__)
        _mm_setcsr(csr);
#endif
    }
}

static int setup(void **state)
{
    (void)state;
    fill_arrays();
    return 0;
}

/* Task numbers as people read and type them: camera tasks plain, photon batches "p" and the
 * batch; every label parses back to its number, and nothing else parses. */
static void test_task_labels(void **state)
{
    (void)state;
    char buf[PROTO_TASK_LABEL_MAX];
    assert_string_equal(proto_task_label(0, buf), "0");
    assert_string_equal(proto_task_label(17, buf), "17");
    assert_string_equal(proto_task_label(PROTO_PHOTON_TASK, buf), "p0");
    assert_string_equal(proto_task_label(PROTO_PHOTON_TASK | 31, buf), "p31");
    assert_string_equal(proto_task_label(UINT32_MAX, buf), "p2147483647");
    const uint32_t round[] = {
        0, 1, 99, PROTO_PHOTON_TASK - 1, PROTO_PHOTON_TASK, PROTO_PHOTON_TASK | 5, UINT32_MAX};
    for (size_t i = 0; i < sizeof round / sizeof round[0]; i++) {
        uint32_t t = 12345;
        assert_int_equal(proto_task_parse(proto_task_label(round[i], buf), &t), 0);
        assert_int_equal(t, round[i]);
    }
    uint32_t t = 7;
    /* One spelling: the wire's number of a photon batch is not typed. */
    static const char *const bad[] = {
        "", "p", "-1", "1x", "p-1", "2147483648", "p2147483648", "99999999999", " 1", "P3", "3p"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        if (proto_task_parse(bad[i], &t) != -1)
            fail_msg("'%s' parsed", bad[i]);
    assert_int_equal(proto_task_parse(NULL, &t), -1);
    assert_int_equal(t, 7); /* untouched on failure */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_every_type),
        cmocka_unit_test(test_decoded_message_owns_its_data),
        cmocka_unit_test(test_lent_bundle_points_into_input),
        cmocka_unit_test(test_photon_messages),
        cmocka_unit_test(test_status_all_and_optional_fields),
        cmocka_unit_test(test_version_refusal),
        cmocka_unit_test(test_truncated_at_every_byte),
        cmocka_unit_test(test_lying_container_headers),
        cmocka_unit_test(test_deep_nesting),
        cmocka_unit_test(test_trailing_bytes_and_garbage),
        cmocka_unit_test(test_envelope_errors),
        cmocka_unit_test(test_missing_and_wrong_type_fields),
        cmocka_unit_test(test_values_out_of_range),
        cmocka_unit_test(test_bins_of_wrong_length_and_nonfinite),
        cmocka_unit_test(test_float32_sums),
        cmocka_unit_test(test_float32_width_matches_tilebuf),
        cmocka_unit_test(test_accuracy_fields_strict),
        cmocka_unit_test(test_bad_bundle_paths),
        cmocka_unit_test(test_bundle_limits_are_the_callers),
        cmocka_unit_test(test_list_bounds),
        cmocka_unit_test(test_frame_sequences),
        cmocka_unit_test(test_fuzz_mutations),
        cmocka_unit_test(test_task_labels),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
