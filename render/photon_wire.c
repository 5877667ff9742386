#include "photon_wire.h"

photon_store_t *photon_pass_from_wire(const scene_t *scene, const uint8_t *data, size_t len,
                                      err_t *err)
{
    photon_store_t *store = photon_store_decode(scene, data, len, err);
    if (!store) {
        err_prefix(err, "photon store: ");
        return NULL;
    }
    if (photon_store_finish(store, err)) {
        photon_store_destroy(&store);
        return NULL;
    }
    return store;
}
