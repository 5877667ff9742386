/* ratelimit: at most a fixed number of events per window, for log lines a stranger can make us
 * write (refused handshakes, refused connections: issue 16, item 12). Not thread-safe: one per
 * thread that logs. */
#ifndef PRISMFARM_RATELIMIT_H
#define PRISMFARM_RATELIMIT_H

#include <stdbool.h>
#include <stdint.h>

typedef struct ratelimit {
    double window_s; /* length of a window */
    int burst;       /* events let through per window */
    double start;    /* the current window's start (clock.h seconds) */
    int used;        /* events let through in it */
    uint64_t held;   /* events held back in it */
} ratelimit_t;

ratelimit_t ratelimit_make(int burst, double window_s);

/* Whether the event at time now may be logged. When a new window begins after events were held
 * back, *held_before is their number (to be logged once, "N more ... not logged"), else 0. */
bool ratelimit_allow(ratelimit_t *rl, double now, uint64_t *held_before);

#endif
