/* subsurface_load: the loader's part of pbrt-v4's "subsurface" material (scene.h material_t
 * sss): it makes the material a dielectric of the boundary's index, with the medium's
 * coefficients and the BSSRDF table beneath. Tables are computed once per (g, eta) and shared
 * by the materials that have those (the scene owns them). */
#ifndef PRISMFARM_SUBSURFACE_LOAD_H
#define PRISMFARM_SUBSURFACE_LOAD_H

#include "err.h"
#include "scene.h"
#include "scene_desc.h"

/* Completes m from the description dm (kind MATERIAL_SUBSURFACE) once the caller has
 * built m->sss's four textures from dm's sigma_a, sss_sigma_s, reflectance and sss_mfp: kind,
 * ior, scale and the table. 0, or -1 with err set (out of memory). */
int subsurface_load(scene_t *sc, const scene_material_t *dm, material_t *m, err_t *err);

#endif
