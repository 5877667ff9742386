/* pbrt-v4's "interface" (also "" and "none"): no surface, a boundary between media that rays
 * cross straight (render/shading.c, render/render.c). Nothing to load, no BSDF. */
#include "material_class.h"

const material_class_t material_interface = {.name = "interface",
                                             .aliases = (const char *const[]){"", "none", NULL}};
