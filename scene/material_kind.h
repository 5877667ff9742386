/* material_kind: the registry of material classes, the one list that says which materials exist.
 * Each line names a kind and its class's definition (scene/material_<name>.c, material_class.h);
 * the class carries its scene-file name and aliases, so the enum below, the loader's name table
 * with its "unsupported material" message (material_class_lookup) and every report's name
 * (material_kind_name) are derived from this list and the classes. The description keeps the
 * type a file wrote as a string (scene_desc.h, scene_material_t.type): scenefile/ knows no
 * material. The order is the one messages list the names in.
 *
 * A line is needed because C has no constructor that would let a class register itself: the
 * list is what links the class in and gives its kind a value. Two kinds exist only in the
 * description: a uniaxial crystal and a subsurface material load as MATERIAL_DIELECTRIC with
 * their extras, so every kernel that handles glass handles them. */
#ifndef PRISMFARM_MATERIAL_KIND_H
#define PRISMFARM_MATERIAL_KIND_H

#include <stddef.h>

#define MATERIAL_CLASS_LIST(X)                                                                     \
    X(MATERIAL_DIFFUSE, material_diffuse)       /* Lambertian with a reflectance texture */        \
    X(MATERIAL_CONDUCTOR, material_conductor)   /* Fresnel from eta/k; a mirror when smooth */     \
    X(MATERIAL_DIELECTRIC, material_dielectric) /* glass with an index model; smooth or rough */   \
    X(MATERIAL_THIN_DIELECTRIC, material_thindielectric) /* reflection, straight through */        \
    X(MATERIAL_DIFFUSE_TRANSMISSION, material_diffusetransmission) /* Lambertian both ways */      \
    X(MATERIAL_COATED_DIFFUSE, material_coateddiffuse)     /* a coat over a medium over diffuse */ \
    X(MATERIAL_COATED_CONDUCTOR, material_coatedconductor) /* a coat over a medium over metal */   \
    X(MATERIAL_MIX, material_mix)               /* one of two materials, chosen per hit */         \
    X(MATERIAL_UNIAXIAL, material_uniaxial)     /* birefringent crystal (description only) */      \
    X(MATERIAL_INTERFACE, material_interface)   /* no surface: a boundary between media */         \
    X(MATERIAL_POLARISER, material_polarizer)   /* a thin linear polariser sheet */                \
    X(MATERIAL_RETARDER, material_retarder)     /* a thin linear retarder sheet (wave plate) */    \
    X(MATERIAL_MEASURED, material_measured)     /* RGL's measured BSDF data */                     \
    X(MATERIAL_HAIR, material_hair)             /* a hair fibre */                                 \
    X(MATERIAL_SUBSURFACE, material_subsurface) /* BSSRDF under glass (description only) */

#define MATERIAL_KIND_ENUM(kind, name) kind,
typedef enum material_kind {
    MATERIAL_CLASS_LIST(MATERIAL_KIND_ENUM) MATERIAL_KIND_COUNT
} material_kind_t;
#undef MATERIAL_KIND_ENUM

/* The size of the kind's class record (material_class_t.data_size); 0 for none or a value
 * outside the enum. scene.c copies a record by it without seeing the classes. */
size_t material_kind_data_size(material_kind_t kind);

/* The kind's scene-file name ("diffuse", "thindielectric", ...: its class's); "?" for a value
 * outside the enum. */
const char *material_kind_name(material_kind_t kind);

#endif
