#include "tilegrid.h"

tilegrid_t tilegrid_make(int xres, int yres, int tile)
{
    tilegrid_t g = {.xres = xres, .yres = yres, .tile = tile};
    g.tiles_x = (xres + tile - 1) / tile;
    g.tiles_y = (yres + tile - 1) / tile;
    return g;
}

int tilegrid_count(const tilegrid_t *g)
{
    return g->tiles_x * g->tiles_y;
}

void tilegrid_rect(const tilegrid_t *g, int index, int *x0, int *y0, int *w, int *h)
{
    *x0 = (index % g->tiles_x) * g->tile;
    *y0 = (index / g->tiles_x) * g->tile;
    *w = g->xres - *x0 < g->tile ? g->xres - *x0 : g->tile;
    *h = g->yres - *y0 < g->tile ? g->yres - *y0 : g->tile;
}
