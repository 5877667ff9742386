/* dash_assets: the dashboard's front end (dashboard/www: HTML, CSS, vanilla JavaScript), built
 * into the binary by dashboard/embed.cmake so that an installed master needs no data folder
 * and nothing is downloaded, at build time or when a page opens. */
#ifndef PRISMFARM_DASH_ASSETS_H
#define PRISMFARM_DASH_ASSETS_H

#include <stddef.h>

typedef struct dash_asset {
    const char *path; /* "/index.html", "/app.js", ... */
    const char *content_type;
    const unsigned char *data;
    size_t size;
} dash_asset_t;

/* The asset served at path ("/" is "/index.html"); NULL when none. */
const dash_asset_t *dash_asset_find(const char *path);

#endif
