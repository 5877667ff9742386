#include "spool.h"

#include "files.h"

#include "bundle.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* Deepest folder nesting rm_tree descends: bundles have at most PROTO_MAX_PATH_DEPTH
 * components, so anything deeper was not made by the spool. */
#define RM_TREE_DEPTH_MAX (PROTO_MAX_PATH_DEPTH + 4)

struct spool {
    char *dir;
    int lock_fd;          /* DIR/lock, flock'ed for the spool's life */
    unsigned long staged; /* counter naming folders in tmp/ */
};

/* mkdir -p: creates every missing folder of path. */
static int make_dirs(const char *path, err_t *err)
{
    size_t n = strlen(path);
    char *buf = malloc(n + 1);
    if (!buf)
        return err_set(err, "out of memory");
    memcpy(buf, path, n + 1);
    for (char *p = buf + 1;; p++) {
        if (*p != '/' && *p)
            continue;
        char c = *p;
        *p = 0;
        if (mkdir(buf, 0755) < 0 && errno != EEXIST) {
            int e = errno;
            err_set(err, "cannot create folder '%s': %s", buf, strerror(e));
            free(buf);
            return -1;
        }
        if (!c)
            break;
        *p = c;
    }
    free(buf);
    struct stat st;
    if (stat(path, &st) < 0 || !S_ISDIR(st.st_mode))
        return err_set(err, "'%s' is not a folder", path);
    return 0;
}

static int rm_tree(const char *path)
{
    return files_remove_tree(path, RM_TREE_DEPTH_MAX);
}

/* Takes DIR/lock with flock (released by the kernel when the process dies, however it dies) and
 * writes our pid in it for the message of the next master that tries. A master that finds it
 * taken refuses to start: two masters on one spool would hand out the same job ids and
 * overwrite each other's journal rows. */
static int lock_spool(spool_t *self, err_t *err)
{
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/lock", self->dir);
    int fd = open(path, O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0)
        return err_set(err, "cannot open the spool's lock file '%s': %s", path, strerror(errno));
    if (flock(fd, LOCK_EX | LOCK_NB) < 0) {
        int e = errno;
        char pid[32] = "";
        ssize_t n = e == EWOULDBLOCK ? pread(fd, pid, sizeof pid - 1, 0) : -1;
        (void)close(fd);
        if (e != EWOULDBLOCK)
            return err_set(err, "cannot lock the spool's lock file '%s': %s", path, strerror(e));
        pid[n > 0 ? n : 0] = 0;
        pid[strcspn(pid, "\n")] = 0;
        return err_set(err,
                       "the spool '%s' is in use by another master (%s%s, holding '%s'): stop it "
                       "first, or give this one another --spool",
                       self->dir, pid[0] ? "pid " : "pid unknown", pid, path);
    }
    char text[32];
    int len = snprintf(text, sizeof text, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) < 0 || pwrite(fd, text, (size_t)len, 0) != len) {
        int e = errno;
        (void)close(fd);
        return err_set(err, "cannot write the spool's lock file '%s': %s", path, strerror(e));
    }
    self->lock_fd = fd;
    return 0;
}

spool_t *spool_new(const char *dir, err_t *err)
{
    if (!dir || !*dir) {
        err_set(err, "spool folder name is empty");
        return NULL;
    }
    size_t n = strlen(dir);
    if (n > PATH_MAX - 200) {
        err_set(err, "spool folder name is too long (%zu bytes)", n);
        return NULL;
    }
    spool_t *self = calloc(1, sizeof *self);
    if (!self || !(self->dir = malloc(n + 1))) {
        free(self);
        err_set(err, "out of memory");
        return NULL;
    }
    self->lock_fd = -1;
    memcpy(self->dir, dir, n + 1);
    while (n > 1 && self->dir[n - 1] == '/')
        self->dir[--n] = 0;
    char sub[PATH_MAX];
    static const char *const subs[] = {"scenes", "jobs", "tmp"};
    if (make_dirs(self->dir, err) < 0 || lock_spool(self, err) < 0)
        goto fail;
    snprintf(sub, sizeof sub, "%s/tmp", self->dir);
    if (rm_tree(sub) < 0) {
        err_set(err, "cannot empty '%s': %s", sub, strerror(errno));
        goto fail;
    }
    for (int i = 0; i < 3; i++) {
        snprintf(sub, sizeof sub, "%s/%s", self->dir, subs[i]);
        if (mkdir(sub, 0755) < 0 && errno != EEXIST) {
            err_set(err, "cannot create folder '%s': %s", sub, strerror(errno));
            goto fail;
        }
    }
    return self;
fail:
    if (self->lock_fd >= 0)
        (void)close(self->lock_fd);
    free(self->dir);
    free(self);
    return NULL;
}

void spool_destroy(spool_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    if ((*self_p)->lock_fd >= 0)
        (void)close((*self_p)->lock_fd); /* releases the flock */
    free((*self_p)->dir);
    free(*self_p);
    *self_p = NULL;
}

const char *spool_path(const spool_t *self)
{
    return self->dir;
}

uint64_t spool_last_job_id(const spool_t *self)
{
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/jobs", self->dir);
    DIR *d = opendir(path);
    if (!d)
        return 0;
    uint64_t last = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        const char *s = e->d_name;
        if (!*s || strspn(s, "0123456789") != strlen(s) || strlen(s) > 19)
            continue;
        uint64_t v = strtoull(s, NULL, 10);
        if (v > last)
            last = v;
    }
    (void)closedir(d);
    return last;
}

static void scene_paths(const spool_t *self, const char *hash, char *dir, char *file)
{
    snprintf(dir, PATH_MAX, "%s/scenes/%s", self->dir, hash);
    snprintf(file, PATH_MAX, "%s/scenes/%s.scene", self->dir, hash);
}

static int check_hash(const char *hash, err_t *err)
{
    if (!hash || strlen(hash) != PROTO_HASH_HEX ||
        strspn(hash, "0123456789abcdef") != PROTO_HASH_HEX)
        return err_set(err, "'%.80s' is not a scene hash", hash ? hash : "(null)");
    return 0;
}

int spool_scene_stage(spool_t *self, const proto_bundle_t *bundle, const char *hash, char *dir,
                      size_t size, bool *staged, err_t *err)
{
    *staged = false;
    if (check_hash(hash, err) < 0)
        return -1;
    char final[PATH_MAX], file[PATH_MAX];
    scene_paths(self, hash, final, file);
    struct stat st;
    if (lstat(final, &st) == 0 && S_ISDIR(st.st_mode)) {
        if (snprintf(dir, size, "%s", final) >= (int)size)
            return err_set(err, "path too long: '%s'", final);
        return 0;
    }
    if (snprintf(dir, size, "%s/tmp/%s.%lu", self->dir, hash, ++self->staged) >= (int)size)
        return err_set(err, "path too long below '%s'", self->dir);
    (void)rm_tree(dir);
    if (proto_bundle_extract(bundle, dir, true, err) < 0) {
        (void)rm_tree(dir);
        return -1;
    }
    *staged = true;
    return 0;
}

int spool_scene_encode(const proto_bundle_t *bundle, const char *hash, const proto_limits_t *limits,
                       uint8_t **out, size_t *size, err_t *err)
{
    if (check_hash(hash, err) < 0)
        return -1;
    proto_msg_t m = {.type = PROTO_SCENE, .scene = {.bundle = *bundle}};
    memcpy(m.scene.scene, hash, PROTO_HASH_HEX + 1);
    /* Sized once for the whole message: an sbuffer left to grow by doubling would hold its old
     * and its new block at once (a 100 MB bundle peaked at 3 copies in the master, 2 with this). */
    size_t cap = 1024 + strlen(bundle->main);
    for (size_t i = 0; i < bundle->nfiles; i++)
        cap += bundle->files[i].size + strlen(bundle->files[i].path) + 32;
    msgpack_sbuffer buf;
    msgpack_sbuffer_init(&buf);
    buf.data = malloc(cap);
    if (!buf.data)
        return err_set(err, "storing scene %.12s: out of memory for %zu bytes", hash, cap);
    buf.alloc = cap;
    if (proto_encode(&m, limits, &buf, err) < 0) {
        msgpack_sbuffer_destroy(&buf);
        return err_prefix(err, "storing scene %.12s: ", hash);
    }
    *out = (uint8_t *)buf.data; /* msgpack's sbuffer is malloc'ed: the caller frees it */
    *size = buf.size;
    return 0;
}

int spool_scene_commit(const spool_t *self, const uint8_t *scene_msg, size_t size, const char *hash,
                       const char *dir, bool staged, err_t *err)
{
    if (check_hash(hash, err) < 0)
        return -1;
    char final[PATH_MAX], file[PATH_MAX];
    scene_paths(self, hash, final, file);
    if (access(file, F_OK) < 0 && files_write_atomic(file, scene_msg, size, true, err) < 0)
        return err_prefix(err, "storing scene %.12s: ", hash);
    if (staged && rename(dir, final) < 0) {
        int e = errno;
        /* Another submission of the same bundle got there first: keep that copy. */
        if (e == EEXIST || e == ENOTEMPTY) {
            (void)rm_tree(dir);
            return 0;
        }
        return err_set(err, "cannot rename '%s' to '%s': %s", dir, final, strerror(e));
    }
    return 0;
}

void spool_scene_discard(spool_t *self, const char *dir, bool staged)
{
    (void)self;
    if (staged)
        (void)rm_tree(dir);
}

int spool_scene_read(spool_t *self, const char *hash, const proto_limits_t *limits,
                     proto_msg_t *out, err_t *err)
{
    memset(out, 0, sizeof *out);
    if (check_hash(hash, err) < 0)
        return -1;
    proto_limits_t lim = limits ? *limits : proto_limits_default();
    char final[PATH_MAX], file[PATH_MAX];
    scene_paths(self, hash, final, file);
    uint8_t *data;
    size_t size;
    if (files_read(file, lim.max_message_bytes, &data, &size, err) < 0)
        return -1;
    /* The scene's files point into data until the message is freed: held once, not twice. */
    int rc = proto_decode_lent(data, size, &lim, out, free, data, err);
    if (rc < 0) {
        free(data);
        return err_prefix(err, "'%s': ", file);
    }
    if (out->type != PROTO_SCENE || strcmp(out->scene.scene, hash) != 0) {
        proto_msg_free(out);
        return err_set(err, "'%s' does not hold scene %s", file, hash);
    }
    return 0;
}

int spool_job_dir(spool_t *self, uint64_t job, char *buf, size_t size, err_t *err)
{
    if (snprintf(buf, size, "%s/jobs/%llu", self->dir, (unsigned long long)job) >= (int)size)
        return err_set(err, "path too long below '%s'", self->dir);
    if (mkdir(buf, 0755) < 0 && errno != EEXIST)
        return err_set(err, "cannot create folder '%s': %s", buf, strerror(errno));
    return 0;
}
