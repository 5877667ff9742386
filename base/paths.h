/* paths: lexical arithmetic on '/'-separated file names: join, normalise ("." dropped,
 * "x/.." folded), relative forms, containment. Touches nothing on disk except
 * paths_absolute, which reads the working folder. Every returned string is malloc'ed (NULL
 * when out of memory). */
#ifndef PRISMFARM_PATHS_H
#define PRISMFARM_PATHS_H

#include <stdbool.h>

char *paths_resolve(const char *base, const char *name);
char *paths_normalise(const char *path);
char *paths_folder(const char *file);
char *paths_absolute(const char *path);
char *paths_relative_to(const char *dir, const char *path);
bool paths_is_under(const char *dir, const char *path);
char *paths_lexical(const char *path);

#endif
