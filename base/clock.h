/* clock: the one monotonic clock of prismfarm (CLOCK_MONOTONIC, in seconds as a double), for
 * elapsed times, deadlines and heartbeats. It never goes backwards and is unaffected by changes
 * of the wall clock; its zero is arbitrary, so only differences mean anything. */
#ifndef PRISMFARM_CLOCK_H
#define PRISMFARM_CLOCK_H

/* Seconds since an arbitrary fixed point (the machine's boot, on Linux); nanosecond resolution. */
double clock_now_s(void);

/* Sleeps s seconds (nothing for s <= 0), resumed after a signal until the time has passed. */
void clock_sleep_s(double s);

#endif
