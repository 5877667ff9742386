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

/* What kind of file st describes, for messages: "a FIFO", "a character device", "a folder"... */
const char *files_kind(unsigned mode);

/* Opens path for reading only if it is a regular file: opened without blocking (a FIFO would
 * block the open until a writer came), checked with fstat, then switched back to blocking
 * reads. Returns the descriptor, or -1 with a message naming the path and what it is. */
int files_open_regular(const char *path, err_t *err);

/* Checks, before anything is rendered or written, that path can become an output file: if it
 * exists it is a regular file (or a link to one; a device, FIFO, socket or folder is refused,
 * never replaced), and its folder exists (it is not created) and is writable. */
int files_check_output(const char *path, err_t *err);

/* Refuses (with the message of files_check_output) a path that exists and is not a regular
 * file; the last check before a rename over it. */
int files_check_replaceable(const char *path, err_t *err);

/* Reads the regular file path, of at most max bytes, into *data (malloc'ed, at least 1 byte
 * even for an empty file) and its length into *size. */
int files_read(const char *path, size_t max, uint8_t **data, size_t *size, err_t *err);

/* Writes data[0..size) to path atomically: PATH.tmpPID (mode 0644, not following a symbolic
 * link), fsync when sync, rename over path, which must not be anything but a regular file
 * (files_check_replaceable: a device node or FIFO is never replaced). Without the fsync the file is whole once renamed
 * and survives the process, not a power cut. */
int files_write_atomic(const char *path, const void *data, size_t size, bool sync, err_t *err);

/* Removes path, a file or a folder with everything below it down to max_depth levels, never
 * following a symbolic link (a link is removed, not what it points to). 0 when it is gone
 * (or was never there), -1 with errno otherwise. */
int files_remove_tree(const char *path, int max_depth);

#endif
