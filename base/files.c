#include "files.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int files_write_atomic(const char *path, const void *data, size_t size, bool sync, err_t *err)
{
    char tmp[PATH_MAX];
    if (snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return err_set(err, "path too long: '%s'", path);
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
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return err_set(err, "cannot open '%s': %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) < 0 || !S_ISREG(st.st_mode)) {
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
