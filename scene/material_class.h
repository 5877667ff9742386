/* material_class: what each kind of material is in the loaded scene, one class per kind, after
 * pbrt-v4's Material classes (materials.h: each keeps its Create and its GetBxDF together):
 * its loading from the scene description into a material_t and its BSDF at a hit. Each class
 * lives in its own file, scene/material_<name>.c, and is registered by one line of
 * MATERIAL_CLASS_LIST; its scene-file name is material_kind.h's. Its load reads its own
 * parameters, which the description keeps unread (scene_desc.h, scene_material_t).
 * The classes are constant data: no state, safe from any thread. */
#ifndef PRISMFARM_MATERIAL_CLASS_H
#define PRISMFARM_MATERIAL_CLASS_H

#include "bsdf.h"
#include "material_kind.h"
#include "scene.h"

struct material_params; /* material_params.h, the loader's own: render/ sees only the BSDFs */

typedef struct material_class {
    /* Reads the material's parameters (mp, material_params.h: pbrt-v4's Material::Create) and
     * fills m. The caller has set m's name and kind (the description's), remaproughness (1) and
     * mix (-1, -1), and completes m afterwards with what every material but mix and interface
     * shares (its bump or normal map), then refuses the parameters nothing read. Returns 0, or
     * -1 with mp->err naming the parameter's place in the scene file. NULL: no parameters. */
    int (*load)(struct material_params *mp, material_t *m);
    /* Fills b's kind and the kind's own fields at sf for the n lanes' wavelengths; the caller
     * (render/shading.c, shading_bsdf) has set b's mode, lanes, microfacets and thin film.
     * NULL: the kind has no BSDF of its own (a mix is resolved before, an interface or a sheet
     * is crossed) and gets the diffuse class's, as a surface without material would. */
    void (*bsdf)(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b);
} material_class_t;

/* Every class, one line each: its kind and its definition's name (defined in
 * scene/material_<name>.c). Uniaxial and subsurface load as dielectrics (material_kind.h):
 * at a hit they are the dielectric class. */
#define MATERIAL_CLASS_LIST(X)                                                                     \
    X(MATERIAL_DIFFUSE, material_diffuse)                                                          \
    X(MATERIAL_CONDUCTOR, material_conductor)                                                      \
    X(MATERIAL_DIELECTRIC, material_dielectric)                                                    \
    X(MATERIAL_INTERFACE, material_interface)                                                      \
    X(MATERIAL_THIN_DIELECTRIC, material_thindielectric)                                           \
    X(MATERIAL_DIFFUSE_TRANSMISSION, material_diffusetransmission)                                 \
    X(MATERIAL_COATED_DIFFUSE, material_coateddiffuse)                                             \
    X(MATERIAL_COATED_CONDUCTOR, material_coatedconductor)                                         \
    X(MATERIAL_MIX, material_mix)                                                                  \
    X(MATERIAL_POLARISER, material_polarizer)                                                      \
    X(MATERIAL_RETARDER, material_retarder)                                                        \
    X(MATERIAL_MEASURED, material_measured)                                                        \
    X(MATERIAL_HAIR, material_hair)                                                                \
    X(MATERIAL_UNIAXIAL, material_uniaxial)                                                        \
    X(MATERIAL_SUBSURFACE, material_subsurface)

#define MATERIAL_CLASS_DECLARE(kind, name) extern const material_class_t name;
MATERIAL_CLASS_LIST(MATERIAL_CLASS_DECLARE)
#undef MATERIAL_CLASS_DECLARE

/* The class of kind; NULL for a value outside the enum. */
const material_class_t *material_class_of(material_kind_t kind);

/* The class's BSDF for m at sf (its kind's, or the diffuse class's when it has none): what
 * shading_bsdf calls once it has set the parts every kind shares. */
void material_class_bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n,
                         bsdf_t *b);

#endif
