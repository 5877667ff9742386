#include "bisect.h"

size_t bisect_lower(const void *table, size_t n, bisect_key_fn key, uint64_t id)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (key(table, mid) < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}
