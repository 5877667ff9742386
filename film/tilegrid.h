/* tilegrid: the cut of an image into square tiles, row-major from the top-left corner, the last
 * column and row clipped to the image. One cut for the master's scheduler, the direct renderer
 * and the tests, so a tile index means the same rectangle everywhere. */
#ifndef PRISMFARM_TILEGRID_H
#define PRISMFARM_TILEGRID_H

typedef struct tilegrid {
    int xres, yres, tile; /* image size and tile edge, all >= 1 */
    int tiles_x, tiles_y; /* tiles per row and per column */
} tilegrid_t;

/* The grid of an xres x yres image in tiles of tile x tile pixels (all >= 1). */
tilegrid_t tilegrid_make(int xres, int yres, int tile);

/* Tiles in the grid: tiles_x * tiles_y. */
int tilegrid_count(const tilegrid_t *g);

/* Tile index's rectangle: corner (x0, y0), size w x h (clipped at the image's edges); index in
 * [0, tilegrid_count). */
void tilegrid_rect(const tilegrid_t *g, int index, int *x0, int *y0, int *w, int *h);

#endif
