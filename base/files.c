#include "files.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

const char *files_kind(unsigned mode)
{
    switch (mode & S_IFMT) {
    case S_IFREG: return "a regular file";
    case S_IFDIR: return "a folder";
    case S_IFIFO: return "a FIFO";
    case S_IFCHR: return "a character device";
    case S_IFBLK: return "a block device";
    case S_IFSOCK: return "a socket";
    case S_IFLNK: return "a symbolic link";
    default: return "not a regular file";
    }
}

int files_open_regular(const char *path, err_t *err)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return err_set(err, "cannot open '%s': %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) < 0) {
        int e = errno;
        (void)close(fd);
        return err_set(err, "cannot open '%s': %s", path, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        (void)close(fd);
        return err_set(err, "'%s' is %s, not a regular file", path, files_kind(st.st_mode));
    }
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) < 0) {
        int e = errno;
        (void)close(fd);
        return err_set(err, "cannot open '%s': %s", path, strerror(e));
    }
    return fd;
}

int files_check_replaceable(const char *path, err_t *err)
{
    struct stat st;
    if (stat(path, &st) < 0) {
        if (errno == ENOENT && lstat(path, &st) == 0) /* a dangling link: rename replaces it */
            return 0;
        return errno == ENOENT ? 0 : err_set(err, "cannot check '%s': %s", path, strerror(errno));
    }
    if (!S_ISREG(st.st_mode))
        return err_set(err,
                       "'%s' is %s: outputs are written only as regular files, and it is left "
                       "as it is",
                       path, files_kind(st.st_mode));
    return 0;
}

int files_check_output(const char *path, err_t *err)
{
    if (!path || !*path)
        return err_set(err, "the output file name is empty");
    if (files_check_replaceable(path, err) < 0)
        return -1;
    char dir[PATH_MAX];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == path)
        snprintf(dir, sizeof dir, "/");
    else if (snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path) >= (int)sizeof dir)
        return err_set(err, "path too long: '%s'", path);
    if (slash && !slash[1])
        return err_set(err, "the output '%s' names a folder, not a file", path);
    struct stat st;
    if (stat(dir, &st) < 0)
        return err_set(err, "cannot write '%s': the folder '%s' %s", path, dir,
                       errno == ENOENT ? "does not exist (create it first)" : strerror(errno));
    if (!S_ISDIR(st.st_mode))
        return err_set(err, "cannot write '%s': '%s' is %s, not a folder", path, dir,
                       files_kind(st.st_mode));
    if (access(dir, W_OK | X_OK) < 0)
        return err_set(err, "cannot write '%s': the folder '%s' is not writable: %s", path, dir,
                       strerror(errno));
    return 0;
}

int files_write_atomic(const char *path, const void *data, size_t size, bool sync, err_t *err)
{
    char tmp[PATH_MAX];
    if (snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return err_set(err, "path too long: '%s'", path);
    if (files_check_replaceable(path, err) < 0)
        return -1;
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0)
        return err_set(err, "cannot create '%s': %s", tmp, strerror(errno));
    const uint8_t *p = data;
    size_t left = size;
    while (left > 0) {
        ssize_t n = write(fd, p, left);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0) {
            int e = errno;
            (void)close(fd);
            (void)unlink(tmp);
            return err_set(err, "cannot write '%s': %s", tmp, strerror(e));
        }
        p += n;
        left -= (size_t)n;
    }
    if ((sync && fsync(fd) < 0) || close(fd) < 0) {
        int e = errno;
        (void)unlink(tmp);
        return err_set(err, "cannot write '%s': %s", tmp, strerror(e));
    }
    if (files_check_replaceable(path, err) < 0) {
        (void)unlink(tmp);
        return -1;
    }
    if (rename(tmp, path) < 0) {
        int e = errno;
        (void)unlink(tmp);
        return err_set(err, "cannot rename '%s' to '%s': %s", tmp, path, strerror(e));
    }
    return 0;
}

int files_read(const char *path, size_t max, uint8_t **data, size_t *size, err_t *err)
{
    *data = NULL;
    *size = 0;
    int fd = files_open_regular(path, err);
    if (fd < 0)
        return -1;
    struct stat st;
    if (fstat(fd, &st) < 0) {
        (void)close(fd);
        return err_set(err, "'%s' is not a readable file", path);
    }
    if ((uint64_t)st.st_size > (uint64_t)max) {
        (void)close(fd);
        return err_set(err, "'%s' has %lld bytes, more than the %zu allowed", path,
                       (long long)st.st_size, max);
    }
    size_t n = (size_t)st.st_size;
    uint8_t *buf = malloc(n ? n : 1);
    if (!buf) {
        (void)close(fd);
        return err_set(err, "out of memory for '%s' (%zu bytes)", path, n);
    }
    size_t got = 0;
    while (got < n) {
        ssize_t r = read(fd, buf + got, n - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0) {
            int e = r < 0 ? errno : EIO;
            free(buf);
            (void)close(fd);
            return err_set(err, "cannot read '%s': %s", path, r < 0 ? strerror(e) : "file shrank");
        }
        got += (size_t)r;
    }
    (void)close(fd);
    *data = buf;
    *size = n;
    return 0;
}

static int remove_at(int parent, const char *name, int depth, int max_depth)
{
    if (unlinkat(parent, name, 0) == 0 || errno == ENOENT)
        return 0;
    if ((errno != EISDIR && errno != EPERM) || depth > max_depth)
        return -1;
    int fd = openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0)
        return -1;
    DIR *d = fdopendir(fd);
    if (!d) {
        (void)close(fd);
        return -1;
    }
    int rc = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") &&
            remove_at(dirfd(d), e->d_name, depth + 1, max_depth))
            rc = -1;
    if (closedir(d) < 0)
        rc = -1;
    if (unlinkat(parent, name, AT_REMOVEDIR) < 0 && errno != ENOENT)
        rc = -1;
    return rc;
}

int files_remove_tree(const char *path, int max_depth)
{
    return remove_at(AT_FDCWD, path, 0, max_depth);
}
