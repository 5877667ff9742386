#include "ratelimit.h"

ratelimit_t ratelimit_make(int burst, double window_s)
{
    return (ratelimit_t){.window_s = window_s, .burst = burst, .start = -1e300};
}

bool ratelimit_allow(ratelimit_t *rl, double now, uint64_t *held_before)
{
    *held_before = 0;
    if (now - rl->start >= rl->window_s) {
        *held_before = rl->held;
        rl->start = now;
        rl->used = 0;
        rl->held = 0;
    }
    if (rl->used < rl->burst) {
        rl->used++;
        return true;
    }
    rl->held++;
    return false;
}
