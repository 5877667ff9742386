/* load_instances: ObjectBegin / ObjectInstance as Embree instances: each object instanced at
 * least once becomes one scene object holding its shapes once, and every instance places it. */
#ifndef PRISMFARM_LOAD_INSTANCES_H
#define PRISMFARM_LOAD_INSTANCES_H

#include "loader.h"

/* ObjectInstance as Embree instances: each object that is instanced at least once becomes one
 * scene object holding its shapes once, and every instance places it. Objects never
 * instanced, and empty ones, are left out. */
int load_instances(loader_t *L, err_t *err);

#endif
