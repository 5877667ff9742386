#include "load_instances.h"

#include "load_shapes.h"

#include <stdlib.h>

int load_instances(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    if (d->ninstances == 0)
        return 0;
    int *made = malloc(d->nobjects * sizeof *made);
    if (!made)
        return err_set(err, "out of memory");
    for (size_t i = 0; i < d->nobjects; i++)
        made[i] = -1;
    int r = 0;
    for (size_t i = 0; !r && i < d->ninstances; i++) {
        const scene_instance_t *in = &d->instances[i];
        const scene_object_t *o = &d->objects[in->object];
        if (o->nshapes == 0)
            continue;
        if (made[in->object] < 0) {
            int obj = scene_add_object(L->sc, err);
            if (obj < 0) {
                r = -1;
                break;
            }
            for (size_t k = 0; !r && k < o->nshapes; k++)
                r = load_shapes_add(L, &d->object_shapes[o->first_shape + k], obj, err);
            made[in->object] = obj;
        }
        if (!r && scene_add_instance(L->sc, made[in->object], &in->to_world, err) < 0)
            r = err_prefix(err, "%s:%d:%d: ObjectInstance \"%s\": ", in->loc.file, in->loc.line,
                           in->loc.col, o->name);
    }
    free(made);
    return r;
}
