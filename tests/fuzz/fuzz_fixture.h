/* fuzz_fixture: the scene folder the pbrt fuzzer parses in, and the helpers the harnesses and
 * the seed checker share. The folder holds a few small files a fuzzed scene may name (an
 * include, an include in a subfolder, an ascii and a binary PLY mesh, a PNG), so that Include,
 * plymesh and imagemap are exercised; the scene is parsed confined to the folder, so no input
 * can make the fuzzer read any other file. */
#ifndef PRISMFARM_FUZZ_FIXTURE_H
#define PRISMFARM_FUZZ_FIXTURE_H

#include <stddef.h>
#include <stdint.h>

/* The file names of the folder, as a scene names them (corpus seeds use them). */
#define FUZZ_FIXTURE_INCLUDE "inc.pbrt"
#define FUZZ_FIXTURE_SUB_INCLUDE "sub/inner.pbrt"
#define FUZZ_FIXTURE_PLY_ASCII "quad.ply"
#define FUZZ_FIXTURE_PLY_BINARY "tetra.ply"
#define FUZZ_FIXTURE_PNG "checker.png"

/* Makes a fresh folder under $TMPDIR (else /tmp) named prismfarm-PREFIX-XXXXXX and, if
 * with_files, writes the fixture files into it. dir receives its path. Returns 0, or -1 with a
 * message on stderr. */
int fuzz_fixture_make(const char *prefix, int with_files, char *dir, size_t dir_size);

/* Removes a folder and everything below it (never following a symbolic link). 0 or -1. */
int fuzz_fixture_remove(const char *dir);

/* Writes n bytes to path, replacing it. 0 or -1 (message on stderr). */
int fuzz_fixture_write(const char *path, const void *data, size_t n);

/* Reads a whole file (malloc'ed, NUL-terminated one past *len); NULL with a message on stderr. */
uint8_t *fuzz_fixture_read(const char *path, size_t *len);

#endif
