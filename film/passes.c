#include "passes.h"

/* Each pass doubles the samples so far, so a preview after pass k has 2^(k-1) samples per pixel
 * and the number of passes grows only as log2(spp). */
int passes_bounds(int spp, uint32_t *bounds)
{
    int n = 0;
    uint32_t b = 0;
    if (bounds)
        bounds[0] = 0;
    while (b < (uint32_t)(spp > 0 ? spp : 0)) {
        b = b == 0 ? 1 : 2 * b;
        if (b > (uint32_t)spp)
            b = (uint32_t)spp;
        n++;
        if (bounds)
            bounds[n] = b;
    }
    return n;
}

void passes_range(int spp, uint64_t pass, uint32_t *begin, uint32_t *end)
{
    /* Pass p covers [2^(p-1), 2^p) clipped to spp, pass 0 covers [0, 1): the bounds above. */
    uint64_t s = spp > 0 ? (uint64_t)spp : 0;
    uint64_t b = pass == 0 ? 0 : pass > 63 ? UINT64_MAX : (uint64_t)1 << (pass - 1);
    uint64_t e = pass >= 63 ? UINT64_MAX : (uint64_t)1 << pass;
    *begin = (uint32_t)(b < s ? b : s);
    *end = (uint32_t)(e < s ? e : s);
}
