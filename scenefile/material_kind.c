#include "material_kind.h"

/* Every material prismfarm reads, in the order its messages list them. pbrt-v4 reads "" and
 * "none" as no material too (a boundary between media); "polariser" is the British spelling. */
static const pbrt_name_t NAMES[] = {
    {"diffuse", MATERIAL_DIFFUSE},
    {"conductor", MATERIAL_CONDUCTOR},
    {"dielectric", MATERIAL_DIELECTRIC},
    {"thindielectric", MATERIAL_THIN_DIELECTRIC},
    {"diffusetransmission", MATERIAL_DIFFUSE_TRANSMISSION},
    {"coateddiffuse", MATERIAL_COATED_DIFFUSE},
    {"coatedconductor", MATERIAL_COATED_CONDUCTOR},
    {"mix", MATERIAL_MIX},
    {"uniaxial", MATERIAL_UNIAXIAL},
    {"interface", MATERIAL_INTERFACE},
    {"polarizer", MATERIAL_POLARISER},
    {"retarder", MATERIAL_RETARDER},
    {"measured", MATERIAL_MEASURED},
    {"hair", MATERIAL_HAIR},
    {"subsurface", MATERIAL_SUBSURFACE},
    {NULL, 0},
    {"polariser", MATERIAL_POLARISER},
    {"", MATERIAL_INTERFACE},
    {"none", MATERIAL_INTERFACE},
};

const pbrt_name_t *material_kind_names(size_t *n)
{
    *n = sizeof NAMES / sizeof NAMES[0];
    return NAMES;
}

const char *material_kind_name(material_kind_t kind)
{
    for (size_t i = 0; NAMES[i].name; i++)
        if (NAMES[i].value == (int)kind)
            return NAMES[i].name;
    return "?";
}
