/* fuzz_seeds: writes the message seeds of the fuzz corpus from the protocol's own encoder, and
 * checks that every committed seed is still valid input, so the corpus follows the code.
 *
 *   fuzz_seeds write CORPUS   (re)writes CORPUS/fuzz_proto/<name>.msg, one or more per type
 *   fuzz_seeds check CORPUS   fails unless each generated message equals its committed file,
 *                             every file in CORPUS/fuzz_proto decodes, every file in
 *                             CORPUS/fuzz_ply imports as a mesh, and every file in
 *                             CORPUS/fuzz_pbrt parses and loads in the fuzzer's scene folder
 *
 * ctest runs the check (test "fuzz_seeds"); after a protocol change, run the write command and
 * commit the new seeds (docs/fuzzing.md). */
#define _XOPEN_SOURCE 700 /* opendir */

#include "bundle.h"
#include "fuzz_fixture.h"
#include "mesh_import.h"
#include "pbrt_parser.h"
#include "proto.h"
#include "scene_load.h"
#include "sha256.h"

#include <dirent.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- the message seeds */

enum { TW = 2, TH = 2, TNB = 3, TPIX = TW * TH };

static const char SCENE_TEXT[] =
    "LookAt 0 0 -3  0 0 0  0 1 0\n"
    "Camera \"perspective\" \"float fov\" 40\n"
    "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
    "WorldBegin\n"
    "LightSource \"point\" \"point3 from\" [0 4 -4]\n"
    "Material \"dielectric\" \"string glass\" \"BK7\"\n"
    "Shape \"plymesh\" \"string filename\" \"meshes/tri.ply\"\n";
static const char PLY_TEXT[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 1\n"
                               "property list uchar int vertex_indices\nend_header\n"
                               "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

typedef struct seeds {
    double sums[TPIX * TNB], xyz[TPIX * PROTO_TILE_XYZ], lum[TPIX], lum_sq[TPIX];
    uint64_t counts[TPIX];
    proto_bundle_file_t files[2];
    proto_bundle_t bundle;
    char hash[PROTO_HASH_HEX + 1];
    proto_job_info_t jobs[2], sequence[3];
    proto_frame_t frames[2];
    proto_worker_info_t workers[2];
    uint8_t png[8];
    uint8_t store_data[24]; /* opaque to the decoder: a photon store's wire form */
    char store_hash[PROTO_HASH_HEX + 1];
} seeds_t;

static int seeds_init(seeds_t *s, err_t *err)
{
    memset(s, 0, sizeof *s);
    for (int i = 0; i < TPIX * TNB; i++)
        s->sums[i] = 0.25 * i;
    for (int i = 0; i < TPIX * PROTO_TILE_XYZ; i++)
        s->xyz[i] = 0.125 * i;
    for (int i = 0; i < TPIX; i++) {
        s->counts[i] = 16;
        s->lum[i] = 0.5 * i;
        s->lum_sq[i] = 0.25 * i * i;
    }
    s->files[0] =
        (proto_bundle_file_t){"scene.pbrt", (const uint8_t *)SCENE_TEXT, sizeof SCENE_TEXT - 1};
    s->files[1] =
        (proto_bundle_file_t){"meshes/tri.ply", (const uint8_t *)PLY_TEXT, sizeof PLY_TEXT - 1};
    s->bundle = (proto_bundle_t){"scene.pbrt", s->files, 2};
    s->jobs[0] =
        (proto_job_info_t){1, "prism",         JOB_RUNNING, 100, 4096, 2.5, NULL, 0,    0,    false,
                           0, PROTO_STOP_NONE, "alice",     5,   0,    0,   0,    2000, 10000};
    s->jobs[1] = (proto_job_info_t){2,
                                    "gem",
                                    JOB_FAILED,
                                    0,
                                    64,
                                    0.0,
                                    "scene.pbrt:3:7: unsupported shape \"torus\"",
                                    1,
                                    0,
                                    false,
                                    0,
                                    PROTO_STOP_NONE,
                                    NULL,
                                    0,
                                    0,
                                    0,
                                    0,
                                    0,
                                    0};
    /* A frame sequence of two frames (ids 3, 4 after the sequence's 2), the second numbered 0. */
    s->sequence[0] =
        (proto_job_info_t){2, "walk",          JOB_RUNNING, 10, 128, 1.0, NULL, 0, 0, false,
                           0, PROTO_STOP_NONE, NULL,        0,  2,   0,   0,    0, 0};
    s->sequence[1] =
        (proto_job_info_t){3, "scene",         JOB_DONE, 64, 64, 0.5, NULL, 0, 16, false,
                           0, PROTO_STOP_NONE, NULL,     0,  0,  2,   7,    0, 0};
    s->sequence[2] =
        (proto_job_info_t){4, "tri",           JOB_QUEUED, 0, 64, 0.0, NULL, 0, 0, false,
                           0, PROTO_STOP_NONE, NULL,       0, 0,  2,   0,    0, 0};
    s->frames[0] = (proto_frame_t){"scene.pbrt", 7};
    s->frames[1] = (proto_frame_t){"meshes/tri.ply", 0};
    s->workers[0] = (proto_worker_info_t){"node01", 1, 8, PROTO_WORKER_BUSY, 12, 0.5, 0, 0, 0, 2.5e5};
    s->workers[1] =
        (proto_worker_info_t){"node02", 2, 2, PROTO_WORKER_BLOCKED, 0, 1.0, 9, 5, 1, 0};
    memcpy(s->png, "\x89PNG\r\n\x1a\n", 8);
    for (size_t i = 0; i < sizeof s->store_data; i++)
        s->store_data[i] = (uint8_t)(i * 37 + 5);
    sha256_hex_of(s->store_data, sizeof s->store_data, s->store_hash);
    return proto_bundle_hash(&s->bundle, s->hash, err);
}

typedef struct seed {
    const char *name; /* file name without ".msg" */
    proto_msg_t msg;
} seed_t;

enum { NSEEDS_MAX = 64 };

static proto_msg_t *add(seed_t out[NSEEDS_MAX], int *n, const char *name, proto_type_t type)
{
    if (*n >= NSEEDS_MAX) {
        fprintf(stderr, "fuzz_seeds: more than %d seeds listed\n", NSEEDS_MAX);
        abort();
    }
    out[*n] = (seed_t){name, {.type = type}};
    return &out[(*n)++].msg;
}

/* Every message type at least once, and the variants a mutation is unlikely to reach: a
 * version-2 REFUSE (decoded whatever its version), STATUS for all jobs and with a wait, SUBMIT
 * with every setting, an empty JOBS_REPLY, TASK and RESULT of both kinds. Returns the count. */
static int seeds_list(const seeds_t *s, seed_t out[NSEEDS_MAX])
{
    const proto_settings_t all = {64, 320, 240, 7, "whitted", "hero", 0, 0, 0, 1};
    const proto_settings_t keep = {0, 0, 0, -1, NULL, NULL, 0, 0, 0, 0};
    int n = 0;
#define SEED(nm, ty) add(out, &n, nm, ty)
    proto_msg_t *m = SEED("hello", PROTO_HELLO);
    m->hello.name = "node01";
    m->hello.threads = 8;
    m->hello.software = "prismfarm 0.1.0";
    SEED("heartbeat", PROTO_HEARTBEAT);
    m = SEED("result", PROTO_RESULT);
    m->result.job = 1;
    m->result.task = 2;
    m->result.attempt = 1;
    m->result.kind = PROTO_KIND_CAMERA_TILE;
    m->result.tile =
        (proto_tile_result_t){{4, 6, TW, TH, 0, 16}, TNB, s->sums, s->xyz, s->counts, s->lum, s->lum_sq, 0, 0};
    m->result.stats = (proto_task_stats_t){64, 1000, 12, 0.01};
    m = SEED("task_failed", PROTO_TASK_FAILED);
    m->task_failed.job = 1;
    m->task_failed.task = 3;
    m->task_failed.attempt = 2;
    m->task_failed.error = "scene.pbrt:7:7: cannot open PLY file";
    m = SEED("scene_request", PROTO_SCENE_REQUEST);
    memcpy(m->scene_request.scene, s->hash, sizeof s->hash);
    m = SEED("welcome", PROTO_WELCOME);
    m->welcome.worker_id = 42;
    m->welcome.heartbeat_ms = 1000;
    m = SEED("task", PROTO_TASK);
    m->task.job = 1;
    m->task.task = 2;
    m->task.attempt = 1;
    memcpy(m->task.scene, s->hash, sizeof s->hash);
    m->task.settings = keep;
    m->task.kind = PROTO_KIND_CAMERA_TILE;
    m->task.tile = (proto_tile_t){0, 0, 8, 8, 0, 16};
    m = SEED("task_settings", PROTO_TASK);
    m->task.job = 1;
    m->task.task = 3;
    memcpy(m->task.scene, s->hash, sizeof s->hash);
    m->task.settings = all;
    m->task.kind = PROTO_KIND_CAMERA_TILE;
    m->task.tile = (proto_tile_t){8, 0, 8, 8, 16, 32};
    m = SEED("scene", PROTO_SCENE);
    memcpy(m->scene.scene, s->hash, sizeof s->hash);
    m->scene.bundle = s->bundle;
    m = SEED("cancel", PROTO_CANCEL);
    m->cancel.job = 1;
    m = SEED("refuse", PROTO_REFUSE);
    m->refuse.reason = "protocol version 2 not supported by this master (speaks 1)";
    m = SEED("refuse_v2", PROTO_REFUSE);
    m->version = 2;
    m->refuse.reason = "a later master refuses";
    m = SEED("submit", PROTO_SUBMIT);
    m->submit.name = "prism";
    m->submit.settings = keep;
    m->submit.bundle = s->bundle;
    m = SEED("submit_settings", PROTO_SUBMIT);
    m->submit.name = "prism fast";
    m->submit.settings = all;
    m->submit.bundle = s->bundle;
    m = SEED("submit_frames", PROTO_SUBMIT);
    m->submit.name = "walk";
    m->submit.settings = keep;
    m->submit.bundle = s->bundle;
    m->submit.frames = s->frames;
    m->submit.nframes = 2;
    m = SEED("task_frame", PROTO_TASK);
    m->task.job = 3;
    m->task.task = 4;
    memcpy(m->task.scene, s->hash, sizeof s->hash);
    m->task.settings = keep;
    m->task.kind = PROTO_KIND_CAMERA_TILE;
    m->task.tile = (proto_tile_t){0, 8, 8, 8, 0, 16};
    m->task.main = "scene.pbrt";
    m = SEED("status_reply_sequence", PROTO_STATUS_REPLY);
    m->status_reply.jobs = s->sequence;
    m->status_reply.njobs = 3;
    m = SEED("status", PROTO_STATUS);
    m->status.job = 1;
    m = SEED("status_all", PROTO_STATUS);
    m->status.all = true;
    SEED("jobs", PROTO_JOBS);
    SEED("workers", PROTO_WORKERS);
    m = SEED("fetch", PROTO_FETCH);
    m->fetch.job = 1;
    m->fetch.what = PROTO_FETCH_EXR;
    m = SEED("submitted", PROTO_SUBMITTED);
    m->submitted.job = 1;
    m = SEED("status_reply", PROTO_STATUS_REPLY);
    m->status_reply.jobs = s->jobs;
    m->status_reply.njobs = 1;
    m = SEED("jobs_reply", PROTO_JOBS_REPLY);
    m->jobs_reply.jobs = s->jobs;
    m->jobs_reply.njobs = 2;
    m = SEED("jobs_reply_empty", PROTO_JOBS_REPLY);
    m = SEED("workers_reply", PROTO_WORKERS_REPLY);
    m->workers_reply.workers = s->workers;
    m->workers_reply.nworkers = 2;
    m = SEED("file", PROTO_FILE);
    m->file.name = "prism.png";
    m->file.data = s->png;
    m->file.size = sizeof s->png;
    m = SEED("error", PROTO_ERROR);
    m->error.message = "job 9 not found";
    m = SEED("task_store", PROTO_TASK);
    m->task.job = 1;
    m->task.task = 4;
    memcpy(m->task.scene, s->hash, sizeof s->hash);
    memcpy(m->task.store, s->store_hash, sizeof s->store_hash);
    m->task.settings = keep;
    m->task.kind = PROTO_KIND_CAMERA_TILE;
    m->task.tile = (proto_tile_t){0, 8, 8, 8, 0, 16};
    m = SEED("task_photons", PROTO_TASK);
    m->task.job = 1;
    m->task.task = 5;
    memcpy(m->task.scene, s->hash, sizeof s->hash);
    m->task.settings = keep;
    m->task.kind = PROTO_KIND_PHOTON_BATCH;
    m->task.photons = (proto_photon_batch_t){1000, 2000};
    m = SEED("result_photons", PROTO_RESULT);
    m->result.job = 1;
    m->result.task = 5;
    m->result.attempt = 1;
    m->result.kind = PROTO_KIND_PHOTON_BATCH;
    m->result.photons =
        (proto_photon_result_t){{1000, 2000}, 4000, s->store_data, sizeof s->store_data, 0};
    m->result.stats = (proto_task_stats_t){1000, 5000, 900, 0.02};
    m = SEED("status_wait", PROTO_STATUS);
    m->status.job = 1;
    m->status.wait_ms = 5000;
    m = SEED("store_request", PROTO_STORE_REQUEST);
    memcpy(m->store_request.store, s->store_hash, sizeof s->store_hash);
    m = SEED("store", PROTO_STORE);
    memcpy(m->store.store, s->store_hash, sizeof s->store_hash);
    m->store.data = s->store_data;
    m->store.size = sizeof s->store_data;
    m = SEED("refine", PROTO_REFINE);
    m->refine.job = 1;
    m->refine.photons = 1000000;
    m = SEED("progress", PROTO_PROGRESS);
    m->progress.message = "the master is loading the scene (2 s so far)";
    m->progress.elapsed = 2.0;
    m = SEED("act_unblock", PROTO_ACT);
    m->act.act = PROTO_ACT_UNBLOCK;
    m->act.worker = "node07";
    m = SEED("act_requeue", PROTO_ACT);
    m->act.act = PROTO_ACT_REQUEUE;
    m->act.job = 1;
    m->act.task = 3;
    m = SEED("logs", PROTO_LOGS);
    m->logs.job = 1;
    m = SEED("metrics", PROTO_METRICS);
#undef SEED
    return n;
}

/* ---------------------------------------------------------------- commands */

static int join(char *out, size_t n, const char *a, const char *b, const char *c)
{
    int w = snprintf(out, n, "%s/%s%s", a, b, c);
    return w < 0 || (size_t)w >= n ? -1 : 0;
}

/* Every regular entry of dir not starting with '.', sorted, as a NULL-terminated array. */
static char **list_dir(const char *dir, size_t *count)
{
    DIR *d = opendir(dir);
    if (!d) {
        fprintf(stderr, "fuzz_seeds: cannot open %s\n", dir);
        return NULL;
    }
    size_t n = 0, cap = 16;
    char **names = malloc(cap * sizeof *names);
    for (struct dirent *e; names && (e = readdir(d));) {
        if (e->d_name[0] == '.')
            continue;
        if (n + 1 == cap) {
            char **nn = realloc(names, 2 * cap * sizeof *names);
            if (!nn)
                break;
            names = nn;
            cap *= 2;
        }
        names[n++] = strdup(e->d_name);
    }
    closedir(d);
    if (!names)
        return NULL;
    names[n] = NULL;
    for (size_t i = 1; i < n; i++)
        for (size_t j = i; j > 0 && strcmp(names[j - 1], names[j]) > 0; j--) {
            char *t = names[j];
            names[j] = names[j - 1];
            names[j - 1] = t;
        }
    *count = n;
    return names;
}

static void free_list(char **names)
{
    for (size_t i = 0; names && names[i]; i++)
        free(names[i]);
    free(names);
}

/* Encodes every seed; writes each (write) or compares it with its committed file (check). */
static int proto_seeds(const char *corpus, bool write)
{
    err_t err;
    seeds_t s;
    if (seeds_init(&s, &err) != 0) {
        fprintf(stderr, "fuzz_seeds: %s\n", err.msg);
        return 1;
    }
    seed_t list[NSEEDS_MAX];
    int nseeds = seeds_list(&s, list);
    int bad = 0;
    /* A message type without a seed is only reached by mutating another type's name. */
    for (int t = PROTO_NONE + 1; t < PROTO_TYPE_COUNT; t++) {
        bool seeded = false;
        for (int i = 0; i < nseeds; i++)
            seeded = seeded || list[i].msg.type == (proto_type_t)t;
        if (!seeded)
            fprintf(stderr, "fuzz_seeds: warning: no seed of type %s; add one to seeds_list\n",
                    proto_type_name((proto_type_t)t));
    }
    for (int i = 0; i < nseeds; i++) {
        char path[4096];
        if (join(path, sizeof path, corpus, "fuzz_proto/", list[i].name) != 0 ||
            strlen(path) + 5 > sizeof path)
            return 1;
        strcat(path, ".msg");
        msgpack_sbuffer sb;
        msgpack_sbuffer_init(&sb);
        if (proto_encode(&list[i].msg, NULL, &sb, &err) != 0) {
            fprintf(stderr, "fuzz_seeds: %s does not encode: %s\n", list[i].name, err.msg);
            bad++;
        } else if (write) {
            bad += fuzz_fixture_write(path, sb.data, sb.size) != 0;
        } else {
            size_t len;
            uint8_t *old = fuzz_fixture_read(path, &len);
            if (!old || len != sb.size || memcmp(old, sb.data, len) != 0) {
                fprintf(stderr,
                        "fuzz_seeds: %s is not what the encoder writes now; run "
                        "`fuzz_seeds write tests/fuzz/corpus` and commit the seeds\n",
                        path);
                bad++;
            }
            free(old);
        }
        msgpack_sbuffer_destroy(&sb);
    }
    return bad;
}

static int check_messages(const char *corpus)
{
    char dir[4096];
    size_t n;
    char **names = join(dir, sizeof dir, corpus, "fuzz_proto", "") == 0 ? list_dir(dir, &n) : NULL;
    if (!names)
        return 1;
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        char path[8192];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        size_t len;
        uint8_t *data = fuzz_fixture_read(path, &len);
        proto_msg_t m;
        err_t err = {{0}};
        if (!data || proto_decode(data, len, NULL, &m, &err) != 0) {
            fprintf(stderr, "fuzz_seeds: %s does not decode: %s\n", path, err.msg);
            bad++;
        }
        proto_msg_free(&m);
        free(data);
    }
    printf("fuzz_seeds: %zu message seeds decode\n", n);
    free_list(names);
    return bad + (n == 0);
}

static int check_meshes(const char *corpus)
{
    char dir[4096];
    size_t n;
    char **names = join(dir, sizeof dir, corpus, "fuzz_ply", "") == 0 ? list_dir(dir, &n) : NULL;
    if (!names)
        return 1;
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        char path[8192];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        mesh_data_t mesh;
        err_t err = {{0}};
        if (mesh_import_ply(path, &mesh, &err) != 0) {
            fprintf(stderr, "fuzz_seeds: %s does not import: %s\n", path, err.msg);
            bad++;
        }
        mesh_data_free(&mesh);
    }
    printf("fuzz_seeds: %zu PLY seeds import\n", n);
    free_list(names);
    return bad + (n == 0);
}

/* Each scene seed as fuzz_pbrt runs it: copied into the fixture folder, parsed confined, loaded. */
static int check_scenes(const char *corpus)
{
    char dir[4096], fx[4096];
    size_t n;
    char **names = join(dir, sizeof dir, corpus, "fuzz_pbrt", "") == 0 ? list_dir(dir, &n) : NULL;
    if (!names)
        return 1;
    if (fuzz_fixture_make("fuzz-seeds", 1, fx, sizeof fx) != 0) {
        free_list(names);
        return 1;
    }
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        char path[8192], scene[8192];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        snprintf(scene, sizeof scene, "%s/scene.pbrt", fx);
        size_t len;
        uint8_t *text = fuzz_fixture_read(path, &len);
        if (!text || fuzz_fixture_write(scene, text, len) != 0) {
            free(text);
            bad++;
            continue;
        }
        free(text);
        err_t err = {{0}};
        scene_t *sc = scene_load_file_confined(scene, fx, NULL, &err);
        if (!sc) {
            fprintf(stderr, "fuzz_seeds: %s does not load: %s\n", path, err.msg);
            bad++;
        }
        scene_destroy(&sc);
    }
    printf("fuzz_seeds: %zu scene seeds load\n", n);
    fuzz_fixture_remove(fx);
    free_list(names);
    return bad + (n == 0);
}

int main(int argc, char **argv)
{
    if (argc != 3 || (strcmp(argv[1], "write") != 0 && strcmp(argv[1], "check") != 0)) {
        fprintf(stderr, "usage: fuzz_seeds write|check CORPUS\n");
        return 2;
    }
    if (!strcmp(argv[1], "write"))
        return proto_seeds(argv[2], true) ? 1 : 0;
    int bad = proto_seeds(argv[2], false);
    bad += check_messages(argv[2]);
    bad += check_meshes(argv[2]);
    bad += check_scenes(argv[2]);
    if (bad)
        fprintf(stderr, "fuzz_seeds: %d problem(s)\n", bad);
    return bad ? 1 : 0;
}
