/* journal_segments: a job's results, appended to segment files (results/<job>/<seg>.log)
 * and named by rows (segment, offset, size, CRC-32); read back in the scheduler's order,
 * pruned once a checkpoint holds them. */
#include "journal_db.h"


#include "clock.h"
#include "files.h"
#include "sha256.h"
#include "tilebuf.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
static void result_dir(const journal_t *self, uint64_t job, char *buf, size_t size)
{
    snprintf(buf, size, "%s/results/%llu", self->dir, (unsigned long long)job);
}

static void segment_path(const journal_t *self, uint64_t job, uint32_t seg, char *buf,
                         size_t size)
{
    snprintf(buf, size, "%s/results/%llu/%u.log", self->dir, (unsigned long long)job, seg);
}

/* "<seg>.log" -> seg; false for any other name. */
static bool segment_name(const char *name, uint32_t *seg)
{
    unsigned v;
    int used = 0;
    if (sscanf(name, "%u.log%n", &v, &used) != 1 || used == 0 || name[used] != 0)
        return false;
    *seg = v;
    return true;
}

static segment_t *segment_find(journal_t *self, uint64_t job)
{
    for (size_t i = 0; i < self->nsegs; i++)
        if (self->segs[i].job == job)
            return &self->segs[i];
    return NULL;
}

static void segment_close(journal_t *self, uint64_t job)
{
    segment_t *g = segment_find(self, job);
    if (!g)
        return;
    (void)close(g->fd);
    *g = self->segs[--self->nsegs];
}

/* The job's open segment, or a new one numbered past every segment its rows or its folder
 * name: a restarted master never appends to a file a killed one may have left half written. */
static segment_t *segment_open(journal_t *self, uint64_t job, err_t *err)
{
    segment_t *g = segment_find(self, job);
    if (g)
        return g;
    char dir[PATH_MAX];
    result_dir(self, job, dir, sizeof dir);
    if (mkdir(dir, 0755) < 0 && errno != EEXIST) {
        err_set(err, "journal: cannot create '%s': %s", dir, strerror(errno));
        return NULL;
    }
    uint32_t next = 1, seg;
    sqlite3_stmt *st;
    if (jdb_prepare(self, "SELECT MAX(seg) FROM results WHERE job=?1", &st, err) < 0)
        return NULL;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    if (sqlite3_step(st) == SQLITE_ROW && sqlite3_column_type(st, 0) != SQLITE_NULL)
        next = (uint32_t)sqlite3_column_int64(st, 0) + 1;
    sqlite3_finalize(st);
    DIR *d = opendir(dir);
    if (!d) {
        err_set(err, "journal: cannot read '%s': %s", dir, strerror(errno));
        return NULL;
    }
    struct dirent *e;
    while ((e = readdir(d)))
        if (segment_name(e->d_name, &seg) && seg >= next)
            next = seg + 1;
    (void)closedir(d);
    if (self->nsegs == self->capsegs) {
        size_t c = self->capsegs ? 2 * self->capsegs : 4;
        segment_t *p = realloc(self->segs, c * sizeof *p);
        if (!p) {
            err_set(err, "journal: out of memory");
            return NULL;
        }
        self->segs = p;
        self->capsegs = c;
    }
    char path[PATH_MAX + 64];
    segment_path(self, job, next, path, sizeof path);
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
        err_set(err, "journal: cannot create '%s': %s", path, strerror(errno));
        return NULL;
    }
    g = &self->segs[self->nsegs++];
    *g = (segment_t){.job = job, .seg = next, .fd = fd, .size = 0};
    return g;
}

static uint32_t blob_crc(const void *data, size_t size)
{
    uLong c = crc32(0L, Z_NULL, 0);
    const Bytef *p = data;
    while (size > 0) { /* crc32 takes a uInt length */
        uInt n = size > (1u << 30) ? (1u << 30) : (uInt)size;
        c = crc32(c, p, n);
        p += n;
        size -= n;
    }
    return (uint32_t)c;
}

static int add_result(journal_t *self, uint64_t job, uint32_t round, uint32_t task, int kind,
                      int tile, int pass, const void *data, size_t size, err_t *err);

int journal_add_result(journal_t *self, uint64_t job, uint32_t round, uint32_t task, int kind,
                       int tile, int pass, const void *data, size_t size, err_t *err)
{
    double t0 = clock_now_s();
    if (self->in_turn && !self->turn_open) {
        if (jdb_exec(self, "BEGIN IMMEDIATE", err) < 0)
            return -1;
        self->turn_open = true;
        self->t_turn = t0;
    }
    int rc = add_result(self, job, round, task, kind, tile, pass, data, size, err);
    if (!self->turn_open)
        jdb_count_write(self, t0); /* a turn's results count as its one commit */
    return rc;
}

void journal_turn_begin(journal_t *self)
{
    self->in_turn = true;
}

int journal_turn_end(journal_t *self, err_t *err)
{
    self->in_turn = false;
    return jdb_turn_flush(self, err);
}

static int add_result(journal_t *self, uint64_t job, uint32_t round, uint32_t task, int kind,
                      int tile, int pass, const void *data, size_t size, err_t *err)
{
    segment_t *g = segment_open(self, job, err);
    if (!g)
        return -1;
    const uint8_t *p = data;
    uint64_t offset = g->size;
    for (size_t done = 0; done < size;) {
        ssize_t n = pwrite(g->fd, p + done, size - done, (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            char path[PATH_MAX + 64];
            segment_path(self, job, g->seg, path, sizeof path);
            err_set(err, "journal: cannot write to '%s': %s", path, n < 0 ? strerror(errno) : "no progress");
            segment_close(self, job); /* its tail is unknown: the next result starts another */
            return -1;
        }
        done += (size_t)n;
    }
    g->size += size;
    if (!self->add_result &&
        jdb_prepare(self,
                "INSERT OR IGNORE INTO results(job, round, task, kind, tile, pass, size, seg, "
                "offset, crc) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)",
                &self->add_result, err) < 0)
        return -1;
    sqlite3_stmt *st = self->add_result;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int64(st, 2, round);
    sqlite3_bind_int64(st, 3, task);
    sqlite3_bind_int(st, 4, kind);
    sqlite3_bind_int(st, 5, tile);
    sqlite3_bind_int(st, 6, pass);
    sqlite3_bind_int64(st, 7, (sqlite3_int64)size);
    sqlite3_bind_int64(st, 8, g->seg);
    sqlite3_bind_int64(st, 9, (sqlite3_int64)offset);
    sqlite3_bind_int64(st, 10, blob_crc(data, size));
    int rc = sqlite3_step(st) == SQLITE_DONE ? 0 : jdb_error(self, err, "adding a result");
    sqlite3_reset(st);
    return rc;
}

/* A blob of the segment open in *fd (segment *open_seg), opening seg first when it differs.
 * NULL when the file is missing, short, or the bytes are not the ones journaled. */
static uint8_t *read_blob(const journal_t *self, uint64_t job, uint32_t seg, uint64_t offset,
                          size_t size, uint32_t crc, int *fd, uint32_t *open_seg)
{
    if (*fd < 0 || *open_seg != seg) {
        if (*fd >= 0)
            (void)close(*fd);
        char path[PATH_MAX + 64];
        segment_path(self, job, seg, path, sizeof path);
        *fd = open(path, O_RDONLY | O_CLOEXEC);
        *open_seg = seg;
        if (*fd < 0)
            return NULL;
    }
    uint8_t *data = malloc(size ? size : 1);
    if (!data)
        return NULL;
    for (size_t done = 0; done < size;) {
        ssize_t n = pread(*fd, data + done, size - done, (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            free(data);
            return NULL;
        }
        done += (size_t)n;
    }
    if (blob_crc(data, size) != crc) {
        free(data);
        return NULL;
    }
    return data;
}

int journal_results(journal_t *self, uint64_t job, uint32_t round, journal_result_fn fn,
                    void *user, size_t *lost, err_t *err)
{
    *lost = 0;
    sqlite3_stmt *st;
    if (jdb_prepare(self,
                "SELECT task, kind, size, seg, offset, crc FROM results WHERE job=?1 AND "
                "round=?2 ORDER BY kind DESC, pass, tile",
                &st, err) < 0)
        return -1;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int64(st, 2, round);
    int rc, out = 0, fd = -1;
    uint32_t open_seg = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        uint32_t task = (uint32_t)sqlite3_column_int64(st, 0);
        size_t size = (size_t)sqlite3_column_int64(st, 2);
        uint8_t *data = read_blob(self, job, (uint32_t)sqlite3_column_int64(st, 3),
                                  (uint64_t)sqlite3_column_int64(st, 4), size,
                                  (uint32_t)sqlite3_column_int64(st, 5), &fd, &open_seg);
        if (!data) {
            (*lost)++;
            continue;
        }
        int r = fn(user, task, sqlite3_column_int(st, 1), data, size, err);
        free(data);
        if (r < 0) {
            out = -1;
            break;
        }
    }
    if (fd >= 0)
        (void)close(fd);
    if (out == 0 && rc != SQLITE_DONE)
        out = jdb_error(self, err, "reading results");
    sqlite3_finalize(st);
    return out;
}

void journal_prune(journal_t *self, uint64_t job)
{
    /* The next result starts a segment of its own, so that this one can go once the rows in
     * it are dropped (a checkpoint, the job's end). */
    segment_close(self, job);
    char dir[PATH_MAX];
    result_dir(self, job, dir, sizeof dir);
    DIR *d = opendir(dir);
    if (!d)
        return;
    /* The segments the job's rows name: a handful (one per checkpoint interval). */
    uint32_t used[64];
    size_t n = 0;
    bool listed = false;
    sqlite3_stmt *st;
    err_t ignore;
    if (jdb_prepare(self, "SELECT DISTINCT seg FROM results WHERE job=?1", &st, &ignore) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        int rc;
        while ((rc = sqlite3_step(st)) == SQLITE_ROW && n < sizeof used / sizeof *used)
            used[n++] = (uint32_t)sqlite3_column_int64(st, 0);
        /* More segments than the list holds: keep every file rather than guess. */
        listed = rc == SQLITE_DONE;
        sqlite3_finalize(st);
    }
    /* Without the list (a database error) nothing is removed. */
    if (listed) {
        struct dirent *e;
        while ((e = readdir(d))) {
            uint32_t seg;
            if (e->d_name[0] == '.')
                continue;
            bool keep = false;
            if (segment_name(e->d_name, &seg))
                for (size_t i = 0; i < n && !keep; i++)
                    keep = used[i] == seg;
            if (keep)
                continue;
            char path[PATH_MAX + 300];
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
            (void)unlink(path);
        }
    }
    (void)closedir(d);
    if (listed && n == 0)
        (void)rmdir(dir);
}

/* Drops the round's camera rows that the checkpoint holds (tile t's passes below
 * next_pass[t]), inside the caller's transaction. One scan of the round's rows, then a delete by
 * rowid for each: a DELETE per tile would walk every row of the round once per tile (the primary
 * key orders by task, not tile), seconds of the master's loop for a job of 10 000 tiles
 * (docs/performance.md, "The master at scale"). The rowids are gathered first and the scan
 * finished before any row goes, so the deletions never run under an open cursor of the table. */
int jdb_drop_checkpointed(journal_t *self, uint64_t job, uint32_t round, const int *next_pass,
                             int ntiles, err_t *err)
{
    sqlite3_stmt *st;
    if (jdb_prepare(self, "SELECT rowid, tile, pass FROM results WHERE job=?1 AND round=?2 AND kind=0",
                &st, err) < 0)
        return -1;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int64(st, 2, round);
    sqlite3_int64 *ids = NULL;
    size_t n = 0, cap = 0;
    int rc = 0, step = SQLITE_DONE;
    while (rc == 0 && (step = sqlite3_step(st)) == SQLITE_ROW) {
        int tile = sqlite3_column_int(st, 1), pass = sqlite3_column_int(st, 2);
        if (tile < 0 || tile >= ntiles || pass >= next_pass[tile])
            continue;
        if (n == cap) {
            size_t c = cap ? 2 * cap : 1024;
            sqlite3_int64 *p = realloc(ids, c * sizeof *p);
            if (!p) {
                rc = err_set(err, "journal: out of memory dropping checkpointed results");
                break;
            }
            ids = p;
            cap = c;
        }
        ids[n++] = sqlite3_column_int64(st, 0);
    }
    if (rc == 0 && step != SQLITE_DONE)
        rc = jdb_error(self, err, "reading the results a checkpoint holds");
    sqlite3_finalize(st);
    sqlite3_stmt *del = NULL;
    if (rc == 0 && n > 0)
        rc = jdb_prepare(self, "DELETE FROM results WHERE rowid=?1", &del, err);
    for (size_t i = 0; rc == 0 && i < n; i++) {
        sqlite3_bind_int64(del, 1, ids[i]);
        if (sqlite3_step(del) != SQLITE_DONE)
            rc = jdb_error(self, err, "dropping checkpointed results");
        sqlite3_reset(del);
    }
    sqlite3_finalize(del); /* a no-op for NULL */
    free(ids);
    return rc;
}

