/* frame_pattern: the names of a frame sequence's files (docs/farm.md, "Frame sequences"): a
 * printf pattern with one integer conversion (frame%04d.pbrt, out/f%04d.exr) formatted with a
 * frame's number, and the number a listed frame file carries in its name. */
#ifndef PRISMFARM_FRAME_PATTERN_H
#define PRISMFARM_FRAME_PATTERN_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Whether s has a '%' conversion at all ("%%" is a literal '%'). */
bool frame_pattern_has(const char *s);

/* A pattern has exactly one conversion %d, with an optional '0' flag and width (%d, %4d,
 * %04d), and otherwise only "%%". 0, or -1 with err naming the pattern and what is wrong. */
int frame_pattern_check(const char *pattern, err_t *err);

/* The pattern (checked) with number in its conversion, into out; -1 with err when it does not
 * fit in size bytes or the pattern is bad. */
int frame_pattern_format(const char *pattern, uint32_t number, char *out, size_t size, err_t *err);

/* The number in a frame file's name: the last run of digits of its last path component
 * (frame0042.pbrt: 42, shot3_take12.pbrt: 12); false when it has none or it exceeds
 * UINT32_MAX. */
bool frame_pattern_number_of(const char *path, uint32_t *out);

/* "A-B" (A <= B, both 0..UINT32_MAX, at most max frames) into *first, *last; -1 with err. */
int frame_pattern_parse_range(const char *s, size_t max, uint32_t *first, uint32_t *last,
                              err_t *err);

#endif
