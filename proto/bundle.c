#include "bundle.h"

#include "sha256.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int proto_bundle_path_check(const char *path, err_t *err)
{
    if (!path)
        return err_set(err, "path is missing");
    size_t len = strlen(path);
    if (len == 0)
        return err_set(err, "path is empty");
    if (len > PROTO_MAX_STRING)
        return err_set(err, "path has %zu bytes, at most %d allowed", len, PROTO_MAX_STRING);
    if (path[0] == '/')
        return err_set(err, "path '%.64s' is absolute", path);
    int depth = 0;
    const char *c = path;
    for (;;) {
        const char *end = strchr(c, '/');
        size_t n = end ? (size_t)(end - c) : strlen(c);
        if (n == 0)
            return err_set(err, "path '%.64s' has an empty component", path);
        if (n > PROTO_MAX_PATH_COMPONENT)
            return err_set(err, "path '%.64s' has a component of %zu bytes, at most %d allowed",
                           path, n, PROTO_MAX_PATH_COMPONENT);
        if ((n == 1 && c[0] == '.') || (n == 2 && c[0] == '.' && c[1] == '.'))
            return err_set(err, "path '%.64s' has a '%.*s' component", path, (int)n, c);
        for (size_t i = 0; i < n; i++) {
            unsigned char ch = (unsigned char)c[i];
            if (ch < 0x20 || ch == 0x7f || ch == '\\')
                return err_set(err, "path '%.64s' has a forbidden byte 0x%02x", path, ch);
        }
        if (++depth > PROTO_MAX_PATH_DEPTH)
            return err_set(err, "path '%.64s' has more than %d components", path,
                           PROTO_MAX_PATH_DEPTH);
        if (!end)
            return 0;
        c = end + 1;
    }
}

static int compare_paths(const void *a, const void *b)
{
    const proto_bundle_file_t *fa = *(const proto_bundle_file_t *const *)a;
    const proto_bundle_file_t *fb = *(const proto_bundle_file_t *const *)b;
    return strcmp(fa->path, fb->path);
}

static int compare_key(const void *key, const void *elem)
{
    return strcmp(key, (*(const proto_bundle_file_t *const *)elem)->path);
}

/* The files ordered by path (byte order), after checking each path; NULL on failure. */
static const proto_bundle_file_t **sorted_files(const proto_bundle_t *b, err_t *err)
{
    if (b->nfiles > 0 && !b->files) {
        err_set(err, "bundle has %zu files but no file table", b->nfiles);
        return NULL;
    }
    for (size_t i = 0; i < b->nfiles; i++) {
        if (proto_bundle_path_check(b->files[i].path, err) < 0) {
            err_prefix(err, "bundle file %zu: ", i);
            return NULL;
        }
        if (b->files[i].size > 0 && !b->files[i].data) {
            err_set(err, "bundle file '%.64s' has %zu bytes but no data", b->files[i].path,
                    b->files[i].size);
            return NULL;
        }
    }
    const proto_bundle_file_t **sorted = malloc((b->nfiles ? b->nfiles : 1) * sizeof *sorted);
    if (!sorted) {
        err_set(err, "out of memory sorting a bundle of %zu files", b->nfiles);
        return NULL;
    }
    for (size_t i = 0; i < b->nfiles; i++)
        sorted[i] = &b->files[i];
    qsort(sorted, b->nfiles, sizeof *sorted, compare_paths);
    return sorted;
}

/* Paths unique, no file doubling as a folder, main present; sorted as sorted_files made it. */
static int check_sorted(const proto_bundle_t *b, const proto_bundle_file_t **sorted, err_t *err)
{
    if (proto_bundle_path_check(b->main, err) < 0)
        return err_prefix(err, "bundle main file: ");
    if (!bsearch(b->main, sorted, b->nfiles, sizeof *sorted, compare_key))
        return err_set(err, "bundle main file '%.64s' is not among its %zu files", b->main,
                       b->nfiles);
    char prefix[PROTO_MAX_STRING + 1];
    for (size_t i = 0; i < b->nfiles; i++) {
        const char *p = sorted[i]->path;
        if (i > 0 && strcmp(p, sorted[i - 1]->path) == 0)
            return err_set(err, "bundle has the path '%.64s' twice", p);
        for (const char *s = strchr(p, '/'); s; s = strchr(s + 1, '/')) {
            size_t n = (size_t)(s - p);
            memcpy(prefix, p, n);
            prefix[n] = 0;
            if (bsearch(prefix, sorted, b->nfiles, sizeof *sorted, compare_key))
                return err_set(err, "bundle uses '%.64s' both as a file and as a folder", prefix);
        }
    }
    return 0;
}

int proto_bundle_check(const proto_bundle_t *bundle, const proto_limits_t *limits, err_t *err)
{
    proto_limits_t lim = limits ? *limits : proto_limits_default();
    if (bundle->nfiles > lim.max_bundle_files)
        return err_set(err, "bundle has %zu files, at most %zu allowed", bundle->nfiles,
                       lim.max_bundle_files);
    size_t total = 0;
    for (size_t i = 0; i < bundle->nfiles && bundle->files; i++) {
        if (bundle->files[i].size > lim.max_bundle_bytes - total)
            return err_set(err, "bundle files exceed %zu bytes in total", lim.max_bundle_bytes);
        total += bundle->files[i].size;
    }
    const proto_bundle_file_t **sorted = sorted_files(bundle, err);
    if (!sorted)
        return -1;
    int rc = check_sorted(bundle, sorted, err);
    free(sorted);
    return rc;
}

static void hash_u64(sha256_t *s, uint64_t v)
{
    uint8_t le[8];
    for (int i = 0; i < 8; i++)
        le[i] = (uint8_t)(v >> (8 * i));
    sha256_update(s, le, sizeof le);
}

static void hash_string(sha256_t *s, const char *str)
{
    size_t n = strlen(str);
    hash_u64(s, n);
    sha256_update(s, str, n);
}

int proto_bundle_hash(const proto_bundle_t *bundle, char hex[PROTO_HASH_HEX + 1], err_t *err)
{
    const proto_bundle_file_t **sorted = sorted_files(bundle, err);
    if (!sorted)
        return -1;
    if (check_sorted(bundle, sorted, err) < 0) {
        free(sorted);
        return -1;
    }
    /* Canonical form (docs/protocol.md): a tag, the main path, the file count, then each file
     * in byte order of paths as (path, size, bytes), lengths as 8-byte little-endian. */
    static const char tag[] = "prismfarm bundle 1\n";
    sha256_t s;
    sha256_init(&s);
    sha256_update(&s, tag, sizeof tag - 1);
    hash_string(&s, bundle->main);
    hash_u64(&s, bundle->nfiles);
    for (size_t i = 0; i < bundle->nfiles; i++) {
        hash_string(&s, sorted[i]->path);
        hash_u64(&s, sorted[i]->size);
        if (sorted[i]->size > 0)
            sha256_update(&s, sorted[i]->data, sorted[i]->size);
    }
    free(sorted);
    uint8_t digest[SHA256_DIGEST_BYTES];
    sha256_final(&s, digest);
    sha256_hex(digest, hex);
    return 0;
}

/* Opens (creating if needed) the subfolder name of the folder parent, refusing symbolic links. */
static int open_subdir(int parent, const char *name, const char *path, err_t *err)
{
    if (mkdirat(parent, name, 0755) < 0 && errno != EEXIST)
        return err_set(err, "cannot create folder '%s' for '%.64s': %s", name, path,
                       strerror(errno));
    int fd = openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) {
        if (errno == ELOOP || errno == ENOTDIR)
            return err_set(err, "refusing to write '%.64s': '%s' is not a plain folder (%s)", path,
                           name, strerror(errno));
        return err_set(err, "cannot open folder '%s' for '%.64s': %s", name, path, strerror(errno));
    }
    return fd;
}

static int write_all(int fd, const uint8_t *data, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, data, n);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        data += w;
        n -= (size_t)w;
    }
    return 0;
}

/* Writes one file into the folder dirfd under name, through a temporary file and a rename. */
static int write_atomically(int dirfd, const char *name, const proto_bundle_file_t *f, size_t index,
                            bool durable, err_t *err)
{
    char tmp[64];
    snprintf(tmp, sizeof tmp, ".pf-extract-%ld-%zu.tmp", (long)getpid(), index);
    if (unlinkat(dirfd, tmp, 0) < 0 && errno != ENOENT)
        return err_set(err, "cannot remove stale '%s' for '%.64s': %s", tmp, f->path,
                       strerror(errno));
    int fd = openat(dirfd, tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0)
        return err_set(err, "cannot create a temporary file for '%.64s': %s", f->path,
                       strerror(errno));
    int failed = write_all(fd, f->data, f->size) < 0 || (durable && fsync(fd) < 0);
    int saved = errno;
    if (close(fd) < 0 && !failed) {
        failed = 1;
        saved = errno;
    }
    if (!failed && renameat(dirfd, tmp, dirfd, name) < 0) {
        failed = 1;
        saved = errno;
    }
    if (failed) {
        (void)unlinkat(dirfd, tmp, 0); /* best effort: the error below is what matters */
        return err_set(err, "cannot write '%.64s': %s", f->path, strerror(saved));
    }
    return 0;
}

static int extract_file(int root, const proto_bundle_file_t *f, size_t index, bool durable,
                        err_t *err)
{
    char comp[PROTO_MAX_PATH_COMPONENT + 1];
    int dir = root;
    const char *c = f->path;
    int rc = 0;
    for (const char *s = strchr(c, '/'); s; c = s + 1, s = strchr(c, '/')) {
        size_t n = (size_t)(s - c);
        memcpy(comp, c, n);
        comp[n] = 0;
        int sub = open_subdir(dir, comp, f->path, err);
        if (dir != root)
            (void)close(dir); /* read-only folder: nothing to lose */
        if (sub < 0)
            return -1;
        dir = sub;
    }
    rc = write_atomically(dir, c, f, index, durable, err);
    if (dir != root)
        (void)close(dir);
    return rc;
}

int proto_bundle_extract(const proto_bundle_t *bundle, const char *dir, bool durable, err_t *err)
{
    /* Limits were the decoder's business; here only the path rules matter. */
    proto_limits_t unlimited = {SIZE_MAX, SIZE_MAX, SIZE_MAX};
    if (proto_bundle_check(bundle, &unlimited, err) < 0)
        return -1;
    if (mkdir(dir, 0755) < 0 && errno != EEXIST)
        return err_set(err, "cannot create folder '%s': %s", dir, strerror(errno));
    int root = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (root < 0)
        return err_set(err, "cannot open folder '%s': %s", dir, strerror(errno));
    int rc = 0;
    for (size_t i = 0; i < bundle->nfiles && rc == 0; i++)
        rc = extract_file(root, &bundle->files[i], i, durable, err);
    (void)close(root);
    if (rc < 0)
        return err_prefix(err, "extracting into '%s': ", dir);
    return 0;
}
