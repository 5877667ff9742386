/* pbrt_upgrade: a pbrt-v3 scene file's text rewritten as pbrt-v4 text, as `pbrt --upgrade`
 * does (pbrt-v4 src/pbrt/parser.cpp, FormattingParserTarget with upgrade set): WorldEnd
 * dropped, TransformBegin/End as AttributeBegin/End, the v3 materials (uber, plastic, substrate,
 * glass, metal, mirror, matte, translucent, kdsubsurface, disney, mix's namedmaterial1/2, none)
 * as their v4 counterparts, "color" textures and parameters as spectrum and rgb, the scale
 * texture's tex1/tex2, imagemap's trilinear and gamma, Film "image" and its scale, the v3
 * samplers, filters' widths, directlighting, the environment camera, the heterogeneous medium,
 * lights' rgb scale, legacy blackbody and mapname, "area" lights, loopsubdiv's nlevels and
 * trianglemesh's float uv.
 *
 * Guarantees: a statement that needs no change is copied byte for byte (comments and layout
 * kept); each rewritten one is printed anew and named in the warnings with its file:line and
 * what it became. What pbrt-v4 refuses to upgrade (a non-opaque uber, two rgb inputs of a
 * scale texture) is an error naming file:line. Include and Import are copied, not followed:
 * each file is upgraded on its own, as pbrt-v4 does. Output of v4 text is unchanged except for
 * "color" spellings, which become "rgb". */
#ifndef PRISMFARM_PBRT_UPGRADE_H
#define PRISMFARM_PBRT_UPGRADE_H

#include "err.h"
#include "warnings.h"

#include <stddef.h>

/* The upgraded text of text[0..len) (file names it in messages), NUL-terminated and malloc'd,
 * its length in *out_len; what was rewritten goes to w (may be NULL). NULL with err set on a
 * syntax error or what cannot be upgraded. */
char *pbrt_upgrade_text(const char *file, const char *text, size_t len, warnings_t *w,
                        size_t *out_len, err_t *err);

/* For a refusal's message: the pbrt-v4 material pbrt_upgrade_text makes of pbrt-v3's material
 * name (uber, plastic, substrate: coateddiffuse; glass: dielectric; metal, mirror: conductor;
 * matte, disney: diffuse; translucent: diffusetransmission; kdsubsurface: subsurface), or NULL
 * when the name is not one of pbrt-v3's. */
const char *pbrt_upgrade_v3_material(const char *name);

/* The hint every refusal of a pbrt-v3 construct ends with. */
#define PBRT_UPGRADE_HINT                                                                          \
    "a pbrt-v3 file: `prismfarm upgrade FILE -o NEW.pbrt` rewrites it for pbrt-v4, as `pbrt "      \
    "--upgrade` does"

#endif
