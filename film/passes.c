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
