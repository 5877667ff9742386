/* pbrt_limits: what bounds a parse -- the nesting, file and byte limits every parse keeps --
 * and how one parse is asked for (pbrt_parse_opts_t). A header of its own so that the parser's
 * internal state (pbrt_state.h), which needs both, does not include the parser's public header
 * that its own implementation includes (no include circle, tools/check_layout.sh). */
#ifndef PRISMFARM_PBRT_LIMITS_H
#define PRISMFARM_PBRT_LIMITS_H

#include "budget.h"

#include <stdbool.h>
#include <stddef.h>

/* Include/Import nesting limit (the main file counts as one) and the most files one scene
 * may read in total, so that a scene that includes a file many times cannot run for ever. */
#define PBRT_INCLUDE_DEPTH_MAX 16
#define PBRT_FILES_MAX 4096

/* The largest scene text, PLY or PNG file read (any parse bounds scene texts, whose lines the
 * lexer counts in int; a confined parse bounds every file): 512 MiB, PROTO_MAX_BUNDLE_BYTES
 * (proto/proto.h), so no file of a bundle the farm accepts is refused. */
#define PBRT_FILE_BYTES_MAX ((size_t)512 << 20)
/* The most a confined parse reads in all: every file read, counted each time it is read
 * (a file included or a PLY named many times counts each time), plus 64 bytes per pixel of
 * every imagemap or normal-map PNG (its RGBA decoding, the float RGB and alpha, and the
 * texture's four uplift coefficients per texel and pyramid), so that a scene of a few
 * kilobytes cannot make the master or a worker read or decode gigabytes. Four times the
 * largest bundle. */
#define PBRT_TOTAL_BYTES_MAX ((size_t)2 << 30)

/* How pbrt_parse_file_opts parses; all zero is pbrt_parse_file. */
typedef struct pbrt_parse_opts {
    /* Non-NULL: a confined parse in this folder, as pbrt_parse_file_confined. */
    const char *root;
    const scene_budget_t *budget; /* as pbrt_parse_file_confined's; NULL: none */
    /* The threads that decode PLY files and subdivide loopsubdiv shapes (<= 0: all cores).
     * Those meshes are queued as the parse reads their directives and made together when the
     * text has been read; the result is the same for every value: the same meshes in the
     * same shapes, and on failure the same message, the first failure in file order. */
    int threads;
    /* The farm's client reading a scene it will bundle (render without --direct, submit,
     * check): the bundle rule (pbrt_confine_bundle_check) is applied to every file the scene
     * names before the file is read. */
    bool bundle;
} pbrt_parse_opts_t;

#endif
