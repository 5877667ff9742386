/* paths: lexical arithmetic on '/'-separated file names: join, normalise ("." dropped,
 * "x/.." folded), relative forms, containment. Touches nothing on disk except
 * paths_absolute, which reads the working folder. Every returned string is malloc'ed (NULL
 * when out of memory). */
#ifndef PRISMFARM_PATHS_H
#define PRISMFARM_PATHS_H

#include <stdbool.h>

#include <stddef.h>

/* dir(base) + name, unless name is absolute or base has no folder. */
char *paths_resolve(const char *base, const char *name);
/* path with "." dropped and "x/.." folded (a ".." that cannot fold is kept in a relative path,
 * dropped at the root of an absolute one). */
char *paths_normalise(const char *path);
/* The folder part of a file name ("" when it has none). */
char *paths_folder(const char *file);
/* An absolute version of a relative path, against the working folder. */
char *paths_absolute(const char *path);
/* path relative to the folder dir, both relative or both absolute. */
char *paths_relative_to(const char *dir, const char *path);
/* Whether path (absolute, normalised) is the folder dir (same form) or lies under it. */
bool paths_is_under(const char *dir, const char *path);
/* The absolute, lexically normalised form of path. */
char *paths_lexical(const char *path);
/* How many leading ".." components a normalised relative path has ("../../a": 2). */
size_t paths_ups(const char *rel);
/* The folder ups levels above dir (absolute, normalised): "/a/b/c", 2 -> "/a" ("/" at most). */
char *paths_lift(const char *dir, size_t ups);

#endif
