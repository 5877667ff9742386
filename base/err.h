/* err: how every fallible prismfarm function reports failure.
 * A function that can fail returns 0 on success or -1 on failure and, on failure, fills
 * the caller's err_t with one line that names the file, line or field at fault. */
#ifndef PRISMFARM_ERR_H
#define PRISMFARM_ERR_H

#include <stddef.h>

typedef struct err {
    char msg[512];
} err_t;

/* Formats the message into err (which may be NULL) and returns -1, so that a failing
 * function can end with `return err_set(err, "...", ...);`. */
int err_set(err_t *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Prefixes an existing message with more context ("scene.pbrt:12: " + msg); returns -1. */
int err_prefix(err_t *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
