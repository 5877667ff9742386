/* bisect: the binary search of the project's tables kept in id order (the master's jobs and
 * workers, the scheduler's workers), one rule for all of them. It guarantees O(log n) calls of
 * key and the first index whose key is not below id. */
#ifndef PRISMFARM_BISECT_H
#define PRISMFARM_BISECT_H

#include <stddef.h>
#include <stdint.h>

/* The id of element i of the table at table (a caller's struct array or pointer array). */
typedef uint64_t (*bisect_key_fn)(const void *table, size_t i);

/* The first i in [0, n) whose key(table, i) >= id, or n when there is none; the keys must be
 * in increasing order. */
size_t bisect_lower(const void *table, size_t n, bisect_key_fn key, uint64_t id);

#endif
