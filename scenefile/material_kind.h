/* material_kind: the one list of material kinds and their scene-file names, shared by the
 * parser (which looks a Material's type up in the names), the scene description (what a file
 * wrote: scene_desc.h's scene_material_t.kind), the loaded scene (what the kernels see:
 * scene.h's material_t.kind) and every report that names a material (material_kind_name).
 * Two kinds exist only in the description: a uniaxial crystal and a subsurface material load
 * as MATERIAL_DIELECTRIC with their extras (material_t.uniaxial, material_t.sss), so every
 * kernel that handles glass handles them. */
#ifndef PRISMFARM_MATERIAL_KIND_H
#define PRISMFARM_MATERIAL_KIND_H

#include "pbrt_names.h"

#include <stddef.h>

typedef enum material_kind {
    MATERIAL_DIFFUSE,              /* Lambertian with a reflectance texture */
    MATERIAL_CONDUCTOR,            /* Fresnel from eta/k (or a reflectance); a mirror when smooth */
    MATERIAL_DIELECTRIC,           /* glass with an index-of-refraction model; smooth or rough */
    MATERIAL_INTERFACE,            /* no surface: rays pass straight through (a media boundary) */
    MATERIAL_THIN_DIELECTRIC,      /* a thin slab: reflection and straight transmission */
    MATERIAL_DIFFUSE_TRANSMISSION, /* Lambertian reflection and transmission */
    MATERIAL_COATED_DIFFUSE,       /* a dielectric coat over a medium over a diffuse base */
    MATERIAL_COATED_CONDUCTOR,     /* a dielectric coat over a medium over a conductor */
    MATERIAL_MIX,                  /* one of two materials, chosen per hit by amount */
    MATERIAL_POLARISER,            /* prismfarm: a thin linear polariser sheet, crossed straight */
    MATERIAL_RETARDER,             /* prismfarm: a thin linear retarder sheet (a wave plate) */
    MATERIAL_MEASURED,             /* RGL's measured BSDF data (bsdf/measured.h) */
    MATERIAL_HAIR,                 /* a hair fibre (bsdf/hair.h) */
    MATERIAL_UNIAXIAL,   /* prismfarm: a uniaxial birefringent crystal (description only) */
    MATERIAL_SUBSURFACE, /* pbrt-v4's subsurface: a BSSRDF under a dielectric (description only) */
} material_kind_t;

/* The names a scene may write for a material's type, as a pbrt_names table (its value a
 * material_kind_t), in the order messages list them; *n gets the row count. */
const pbrt_name_t *material_kind_names(size_t *n);

/* The kind's scene-file name ("diffuse", "thindielectric", ...); "?" for a value outside the
 * enum. */
const char *material_kind_name(material_kind_t kind);

#endif
