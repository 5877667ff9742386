/* frame_list: the scene operands of `submit` and `render` as a list of frame files with their
 * numbers (docs/farm.md, "Frame sequences"): one scene, several files (a shell glob of frames), or
 * a pattern with --frames FIRST-LAST. Every frame file of a sequence is checked to exist, so a
 * glob that matched nothing, a pattern without --frames or a missing frame is a clear error before
 * any work (one scene missing is left to the loader). */
#ifndef PRISMFARM_FRAME_LIST_H
#define PRISMFARM_FRAME_LIST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct frame_list {
    char **paths;
    uint32_t *numbers; /* the last number in each file's name when all differ, else 1..n */
    size_t n;
    bool sequence; /* several files, or a pattern with --frames (even of one frame) */
} frame_list_t;

/* The nops operands (range: --frames's "A-B", or NULL) into *fl. Returns 0; 2 (a bad command
 * line: a bad pattern or range, a missing frame, too many frames) or 1 (out of memory) with a
 * message on stderr prefixed by "prismfarm CMD: "; *fl is then to be freed all the same. */
int frame_list_parse(frame_list_t *fl, char **ops, size_t nops, const char *range, const char *cmd);
void frame_list_free(frame_list_t *fl);

/* "frame0001..frame0120" for a sequence, "scene" for one scene: the frame files' names without
 * their folders and ".pbrt". */
void frame_list_name(const frame_list_t *fl, char *out, size_t size);

#endif
