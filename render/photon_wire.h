/* photon_wire: the photon store a farm worker receives from the master (the merge of every
 * worker's batches, photon_store.h's wire form) decoded and finished for the camera pass. */
#ifndef PRISMFARM_PHOTON_WIRE_H
#define PRISMFARM_PHOTON_WIRE_H

#include "photon_store.h"
#include "scene.h"

#include <stddef.h>
#include <stdint.h>

/* The master's merged store from its wire form, decoded (strictly) and finished, for the
 * camera pass's render_tile; NULL with err if the bytes are not a store of this scene. */
photon_store_t *photon_pass_from_wire(const scene_t *scene, const uint8_t *data, size_t len,
                                      err_t *err);

#endif
