/* glass: the built-in catalogue of dispersive dielectrics (SCHOTT glasses, fused silica,
 * water, diamond, sapphire, CaF2, and pbrt-v4's glass-* names), a constant table whose every
 * entry names the source of its coefficients. Lookup is case-insensitive by name or alias. */
#ifndef PRISMFARM_GLASS_H
#define PRISMFARM_GLASS_H

#include "dispersion.h"
#include "err.h"

#define GLASS_MAX_ALIASES 4

typedef struct glass {
    const char *name;                       /* canonical, e.g. "N-BK7" */
    const char *aliases[GLASS_MAX_ALIASES]; /* unused slots are NULL */
    const char *description;                /* "SCHOTT borosilicate crown" */
    const char *source;                     /* short citation, e.g. "SCHOTT 2017" */
    ior_model_t ior;
} glass_t;

/* Number of entries, and entry i (NULL when i is out of range), in catalogue order. */
int glass_count(void);
const glass_t *glass_get(int i);

/* The entry whose name or an alias equals name, ignoring ASCII case; NULL if none. */
const glass_t *glass_find(const char *name);

/* As glass_find, but a miss fills err with "unknown glass 'X'". */
const glass_t *glass_lookup(const char *name, err_t *err);

#endif
