/* pbrt_confine: where a file a scene names is looked for, and the security boundary of a
 * confined parse. A scene that came over the network (a bundle extracted into a folder) may
 * name any path: "/etc/passwd", "../../x", a FIFO that blocks open() for ever, /dev/zero that
 * never ends, a symbolic link to any of those. A confined parse reads only regular files that
 * lie inside its root both lexically ("." and ".." folded) and after every symbolic link is
 * followed (realpath), checks each with realpath and stat before opening it (neither opens
 * the file), opens it without following a final link and without blocking, checks the open
 * descriptor again, and reads at most PBRT_FILE_BYTES_MAX bytes of one file and
 * PBRT_TOTAL_BYTES_MAX in all. The lexical path arithmetic is base/paths.h. */
#ifndef PRISMFARM_PBRT_CONFINE_H
#define PRISMFARM_PBRT_CONFINE_H

#include "pbrt_state.h"

#include <stdio.h>

/* fopen(path, "rb") for a regular file only (NULL with errno, or EINVAL and *kind naming what
 * the path is), and the reason it failed, for an unconfined parse. */
FILE *pbrt_confine_open_regular(const char *path, const char **kind);
const char *pbrt_confine_open_failure(const char *kind, char *buf, size_t size);

char *pbrt_confine_locate(parser_t *P, const char *name);
const char *pbrt_confine_scene_path(parser_t *P, const char *name, pbrt_loc_t loc);
int pbrt_confine_inside(const parser_t *P, const char *path);
bool pbrt_confine_present(const parser_t *P, const char *path);
int pbrt_confine_charge(parser_t *P, uint64_t bytes, const pbrt_loc_t *from);
char *pbrt_confine_check(parser_t *P, const char *path, const char *name, const pbrt_loc_t *from,
                         const char *what);
int pbrt_confine_open(parser_t *P, const char *real, const char *name, const char *path,
                      const pbrt_loc_t *from, const char *what, size_t *size);
char *pbrt_confine_read(parser_t *P, const char *real, const char *name, const char *path,
                        const pbrt_loc_t *from, const char *what, size_t *len);
int pbrt_confine_inflate(parser_t *P, char **buf, size_t *len, size_t limit, const char *name,
                         const pbrt_loc_t *from);
int pbrt_confine_charge_png(parser_t *P, const char *real, const char *name, const char *path,
                            const pbrt_loc_t *from);

/* The bundle rule, the one rule by which the farm's client decides which files travel with a
 * job (render without --direct, submit and check apply it; scene_bundle roots the bundle):
 * a file named by an absolute path is refused (it would name another file on the master),
 * and so is a file whose real path (symbolic links followed) lies outside the folder the
 * bundle is rooted at for it: the main file's folder lifted by as many levels as the file's
 * path relative to that folder starts with ".." ("../assets/wood.png" lifts it one level).
 * Checked with realpath before the file is opened, so a refused file is never read. Returns
 * 0 when P->bundle is off, the file passes, or it does not exist (the read says so). */
int pbrt_confine_bundle_check(parser_t *P, const char *path, const char *name, pbrt_loc_t loc);

#endif
