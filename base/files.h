/* files: reading a whole file and writing one atomically, the one way prismfarm does either.
 * A read takes only a regular file (a FIFO would block, a device would never end) and at most
 * the bytes the caller allows; a write goes to a temporary file beside the target, is flushed
 * to disk when asked, and renamed over it, so a reader sees the old file or the new one, never
 * a part. Errors name the path and the system's reason. */
#ifndef PRISMFARM_FILES_H
#define PRISMFARM_FILES_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Reads the regular file path, of at most max bytes, into *data (malloc'ed, at least 1 byte
 * even for an empty file) and its length into *size. */
int files_read(const char *path, size_t max, uint8_t **data, size_t *size, err_t *err);

/* Writes data[0..size) to path atomically: PATH.tmpPID (mode 0644, not following a symbolic
 * link), fsync when sync, rename over path. Without the fsync the file is whole once renamed
 * and survives the process, not a power cut. */
int files_write_atomic(const char *path, const void *data, size_t size, bool sync, err_t *err);

#endif
