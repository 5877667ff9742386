#include "budget.h"

scene_budget_t scene_budget_default(void)
{
    return (scene_budget_t){.shapes = 1000000,
                            .triangles = 100000000,
                            .texels = (uint64_t)1 << 28,
                            .image_bytes = (uint64_t)4 << 30};
}

uint64_t scene_budget_image_bytes(uint64_t xres, uint64_t yres, uint64_t buckets)
{
    uint64_t per = (buckets + 4) * 8; /* the bucket sums, the XYZ sums and the weight, doubles */
    if (xres && yres > UINT64_MAX / xres)
        return UINT64_MAX;
    uint64_t px = xres * yres;
    return px && per > UINT64_MAX / px ? UINT64_MAX : px * per;
}
